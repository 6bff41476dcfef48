"""Boundary regularizers R^fix (Eq. 9), R^cur (Eq. 10) and the preconditioner (Section 7)."""
from __future__ import annotations

import numpy as np

from .._native import core
from ..device_arrays import Buffers, host, is_device
from ..errors import PatternError

# w_i of R^cur: corners bend freely so the angle between two curves can adjust.
CORNER_WEIGHT = 0.1


class Regularizers:
    """R(theta) = R^fix + R^cur over the boundary parameters of a ``Parametrization``,
    measured from ``anchor`` (default the base pattern theta-bar).

    R^cur's T_i is the rotation-and-uniform-scale taking the base chord
    pbar_k - pbar_j (the outline neighbours of vertex i) to the current chord
    p_k - p_j; with it R is quadratic and its Hessian P is constant, which is also
    the preconditioner (prefactorized; needs delta_fix > 0).

    ``objective_fix`` is the R^fix strength inside the objective when it differs from
    the preconditioner's ``delta_fix`` (0: R^fix only keeps P positive definite and does
    not pull the pattern back to the base; an option of a grading, measured in
    docs/grading.md).

    ``use_device("cuda")`` moves ``evaluate`` and ``apply_preconditioner`` to the GPU
    (P^-1 dense in GPU memory, docs/gpu_backend.md); the strengths and P stay in the CPU objects,
    which the GPU copy reads, so ``set_strengths`` and ``add_to_preconditioner`` apply
    to it too.
    """

    # Device memory P^-1 may take: 8 (2 n_theta)^2 bytes, 81 MiB at 60K triangles
    # (docs/gpu_backend.md, "The regularizers, R^seam and P^-1 on the GPU").
    GPU_MAX_BYTES = 512 << 20

    def __init__(self, param, delta_fix: float, delta_cur: float, corner_weight: float = CORNER_WEIGHT, *,
                 objective_fix: float | None = None, anchor=None):
        a = param.arrays
        self.param = param
        weight = np.where(a.corner[param.boundary_ids], float(corner_weight), 1.0)
        loops = []
        for lp in a.loops:
            idx = param.theta_index[lp]
            if np.any(idx < 0):
                raise PatternError("a boundary loop holds a vertex not flagged as boundary")
            loops.append([int(i) for i in idx])
        self.weight = weight
        # The pattern R^fix pulls towards and whose curves R^cur keeps: the base pattern
        # (the paper), or a measurement-aware start (seamfit.opt.level_scale).
        self.anchor = np.ascontiguousarray(param.theta_bar if anchor is None else anchor, dtype=float).reshape(-1, 2)
        if self.anchor.shape != param.theta_bar.shape:
            raise ValueError(f"anchor must have shape {param.theta_bar.shape}, got {self.anchor.shape}")
        self._native = core().Regularizers(self.anchor, loops, weight)
        # P lives in its own instance when the objective's R^fix differs from P's.
        self._precond = self._native
        self._extra = None   # constant block added to P (add_to_preconditioner)
        if objective_fix is not None and float(objective_fix) != float(delta_fix):
            self._precond = core().Regularizers(self.anchor, loops, weight)
        self.set_strengths(delta_fix, delta_cur, objective_fix=objective_fix)
        self._gpu = None
        self._out = Buffers()  # DeviceArray results
        self.device_note = ""   # why use_device("cuda") stayed on the CPU, if it did

    def use_device(self, device: str) -> str:
        """Evaluate R^fix + R^cur and apply P^-1 on "cpu" or "cuda". Returns the device
        used: when P^-1 would not fit (GPU_MAX_BYTES, or half the free memory) everything
        stays on the CPU, with the reason in ``device_note``."""
        from ..device import require_device
        from ..errors import DeviceError, SolveError
        if require_device(device, "the regularizers", SolveError, runnable=False) == "cpu":
            self._gpu, self.device_note = None, ""
            return "cpu"
        need = 8 * (2 * self.param.n_theta) ** 2
        if need > self.GPU_MAX_BYTES:   # known before asking for a device (the native side says the same)
            self._gpu = None
            self.device_note = (f"the preconditioner P^-1 needs {need >> 20} MiB of GPU memory "
                                f"(limit {self.GPU_MAX_BYTES >> 20} MiB)")
            return "cpu"
        require_device("cuda", "the regularizers")
        try:
            self._gpu = core().CudaRegularizers(self._native, self._precond, self.GPU_MAX_BYTES)
        except DeviceError as exc:
            self._gpu, self.device_note = None, str(exc)
            return "cpu"
        self.device_note = ""
        return "cuda"

    @property
    def device(self) -> str:
        return "cpu" if self._gpu is None else "cuda"

    def set_strengths(self, delta_fix: float, delta_cur: float, *, objective_fix: float | None = None) -> None:
        """delta_fix and delta_cur shape P; the objective uses objective_fix (default
        delta_fix, the paper's f) and delta_cur."""
        self.delta_fix, self.delta_cur = float(delta_fix), float(delta_cur)
        self.objective_fix = self.delta_fix if objective_fix is None else float(objective_fix)
        if self._precond is self._native and self.objective_fix != self.delta_fix:
            raise ValueError("build Regularizers with objective_fix to give the objective its own R^fix strength")
        self._native.set_strengths(self.objective_fix, self.delta_cur)
        if self._precond is not self._native:
            self._precond.set_strengths(self.delta_fix, self.delta_cur)

    def evaluate(self, theta):
        """-> (value, {"fix", "cur"}, gradient (n_theta, 2)); a DeviceArray theta gives a
        DeviceArray gradient (this object's buffer, valid until the next call)."""
        if is_device(theta):
            if self._gpu is None:
                v, (rf, rc), g = self._native.evaluate(host(theta))
                return v, {"fix": rf, "cur": rc}, self._out.put("grad", g)
            g = self._out.get("grad", theta.shape[0], 2)
            v, (rf, rc) = self._gpu.evaluate_device(theta, g)
            return v, {"fix": rf, "cur": rc}, g
        theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, 2)
        v, (rf, rc), g = (self._native if self._gpu is None else self._gpu).evaluate(theta)
        return v, {"fix": rf, "cur": rc}, g

    def apply_preconditioner(self, g) -> np.ndarray:
        """P^-1 g with P the (constant) Hessian of the regularizers (on the GPU: P^-1
        rebuilt first when P changed); DeviceArray in, DeviceArray out."""
        if is_device(g):
            if self._gpu is None:
                return self._out.put("precond", self._precond.apply_preconditioner(host(g)))
            out = self._out.get("precond", g.shape[0], 2)
            self._gpu.apply_preconditioner_device(g, out)
            return out
        g = np.ascontiguousarray(g, dtype=float).reshape(-1, 2)
        return (self._precond if self._gpu is None else self._gpu).apply_preconditioner(g)

    def add_to_preconditioner(self, H) -> None:
        """Add a constant sparse matrix over theta flattened to P (None: remove it).
        Used for the Gauss-Newton Hessian of R^seam at the base pattern. A GPU copy of
        P^-1 follows (rebuilt at the next apply_preconditioner)."""
        self._extra = H
        if H is None:
            self._precond.set_extra_hessian(np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0))
            return
        coo = H.tocoo()
        self._precond.set_extra_hessian(coo.row.astype(np.int32), coo.col.astype(np.int32), coo.data.astype(float))

    def hessian(self, *, extra: bool = True):
        """P as a scipy sparse matrix over theta flattened (x0, y0, x1, y1, ...); with
        ``extra=False`` without the block of ``add_to_preconditioner`` (the Hessian of
        R^fix + R^cur alone)."""
        import scipy.sparse as sp

        r, c, v, shape = self._precond.hessian_triplets()
        P = sp.csr_matrix((v, (r, c)), shape=shape)
        if not extra and self._extra is not None:
            P = (P - self._extra).tocsr()
        return P
