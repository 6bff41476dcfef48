"""Boundary-vertex parametrization of a pattern (paper Section 5, Eq. 7-8)."""
from __future__ import annotations

import numpy as np

from .._native import core
from ..device_arrays import Buffers, host, is_device
from ..errors import PatternError
from ._mesh import mesh_arrays


class Parametrization:
    """theta = the boundary vertices (metres) of every panel, in increasing vertex id.

    Interior vertices follow the boundary harmonically (cotangent Laplacian of the base
    pattern, prefactorized): ``pattern(theta)`` gives every vertex, ``adjoint(g)``
    gives (dp/dtheta)^T g for a gradient ``g`` with respect to all pattern vertices.
    """

    # Device memory the GPU's dense interior blocks may take (docs/gpu_backend.md,
    # "The pattern side on the GPU").
    GPU_MAX_BYTES = 4 << 30

    def __init__(self, mesh):
        self.arrays = mesh_arrays(mesh)
        a = self.arrays
        try:
            self._native = core().Parametrization(a.triangles, a.pbar, a.boundary)
        except ValueError as exc:
            raise PatternError(f"cannot parametrize the pattern: {exc}") from exc
        self.boundary_ids = np.asarray(self._native.boundary_ids, dtype=np.int64)
        self.interior_ids = np.asarray(self._native.interior_ids, dtype=np.int64)
        self.pbar = a.pbar
        self.theta_bar = a.pbar[self.boundary_ids].copy()
        # vertex id -> theta row (-1 for interior vertices)
        self.theta_index = np.full(a.n_vertices, -1, dtype=np.int64)
        self.theta_index[self.boundary_ids] = np.arange(len(self.boundary_ids))
        self._gpu = None
        self._out = Buffers()  # DeviceArray results
        self.device_note = ""   # why use_device("cuda") stayed on the CPU, if it did

    def use_device(self, device: str) -> str:
        """Evaluate p(theta) and its adjoint on "cpu" or "cuda" (dense per-panel blocks
        of the interior update in GPU memory). Returns the device used: a pattern
        whose blocks would not fit (GPU_MAX_BYTES, or half the free memory) stays
        on the CPU, with the reason in ``device_note``."""
        from ..device import require_device
        from ..errors import DeviceError, SolveError
        if require_device(device, "the parametrization", SolveError) == "cpu":
            self._gpu = None
            return "cpu"
        try:
            self._gpu = core().CudaPattern(self._native, self.GPU_MAX_BYTES)
        except DeviceError as exc:
            self._gpu, self.device_note = None, str(exc)
            return "cpu"
        return "cuda"

    @property
    def device(self) -> str:
        return "cpu" if self._gpu is None else "cuda"

    @property
    def n_theta(self) -> int:
        return len(self.boundary_ids)

    def pattern(self, theta) -> np.ndarray:
        """p(theta): (n_theta, 2) -> (n_vertices, 2), metres. A DeviceArray theta gives a
        DeviceArray p (this object's buffer, valid until the next call)."""
        return self._apply("pattern", theta, "p", len(self.pbar))

    def adjoint(self, g) -> np.ndarray:
        """(dp/dtheta)^T g: (n_vertices, 2) -> (n_theta, 2); DeviceArray in, DeviceArray out."""
        return self._apply("adjoint", g, "g_theta", self.n_theta)

    def _apply(self, op: str, x, out: str, rows: int):
        """The linear map ``op`` (pattern or adjoint) of x where this object computes: a
        DeviceArray x gives the ``rows`` x 2 DeviceArray buffer ``out``, host arrays host arrays."""
        if is_device(x):
            if self._gpu is None:
                return self._out.put(out, getattr(self._native, op)(host(x)))
            y = self._out.get(out, rows, 2)
            getattr(self._gpu, op + "_device")(self._native, x, y)
            return y
        x = np.ascontiguousarray(x, dtype=float).reshape(-1, 2)
        if self._gpu is not None:
            return getattr(self._gpu, op)(self._native, x)
        return getattr(self._native, op)(x)

    def theta_of(self, p) -> np.ndarray:
        """The parameters of a full pattern p (its boundary vertices)."""
        return np.asarray(p, dtype=float)[self.boundary_ids].copy()

    def laplacian(self):
        """The base-pattern cotangent Laplacian as a scipy sparse matrix."""
        import scipy.sparse as sp

        r, c, v, shape = self._native.laplacian_triplets()
        return sp.csr_matrix((v, (r, c)), shape=shape)
