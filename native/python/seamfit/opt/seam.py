"""The seam-length regularizer R^seam (an addition to the paper's Section 5.1).

The sewing springs keep a seam closed in 3D whatever the two pattern sides measure, so
nothing in the paper's objective keeps a stitch's sides equally long: graded patterns
came out with sides 5-19 mm apart. The sewn mesh pairs the two sides vertex for vertex
(``SewnMesh.stitch_pairs``), so per matched segment, consecutive pairs (a_k, b_k),
(a_k+1, b_k+1) of one stitch,

    R^seam = delta_seam / 2 * sum_k (|p(a_k+1) - p(a_k)| - rho_k |p(b_k+1) - p(b_k)|)^2,

rho_k the base ratio of the two segments (1 on ordinary seams up to meshing round-off, the
gathering ratio on gathered ones). It is zero on the base pattern and a function of theta
only. See docs/optimizer.md ("Seam length").
"""
from __future__ import annotations

import numpy as np

from .._native import core
from ..device_arrays import Buffers, host, is_device


def seam_segments(mesh, param) -> np.ndarray:
    """(S, 4) theta indices (a0, a1, b0, b1) of every matched segment of every stitch."""
    out = []
    for pairs in mesh.stitch_pairs:
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        if len(pairs) < 2:
            continue
        t = param.theta_index[pairs]
        if np.any(t < 0):
            raise ValueError("a stitch pairs a vertex that is not on a panel boundary")
        out.append(np.column_stack([t[:-1, 0], t[1:, 0], t[:-1, 1], t[1:, 1]]))
    return np.vstack(out).astype(np.int32) if out else np.zeros((0, 4), np.int32)


class SeamLength:
    """R^seam over the boundary parameters theta of a ``Parametrization``.

    ``evaluations`` counts the evaluations (never any when delta_seam is 0: callers skip
    the term, as the costs skip theirs), on either device. ``use_device("cuda")`` moves
    ``evaluate`` to the GPU; the strength stays in the CPU object, which the GPU copy reads."""

    def __init__(self, param, mesh, delta_seam: float):
        self.param = param
        self._native = core().SeamLength(param.theta_bar, seam_segments(mesh, param))
        self.set_strength(delta_seam)
        self._gpu = None
        self._out = Buffers()  # DeviceArray results
        self.device_note = ""   # kept for symmetry with Parametrization and Regularizers

    def use_device(self, device: str) -> str:
        """Evaluate R^seam on "cpu" or "cuda"; returns the device used."""
        from ..device import require_device
        from ..errors import SolveError
        if require_device(device, "the seam-length term", SolveError) == "cpu":
            self._gpu = None
            return "cpu"
        self._gpu = core().CudaSeamLength(self._native)
        return "cuda"

    @property
    def device(self) -> str:
        return "cpu" if self._gpu is None else "cuda"

    def set_strength(self, delta_seam: float) -> None:
        self.delta_seam = float(delta_seam)
        self._native.set_strength(self.delta_seam)

    @property
    def active(self) -> bool:
        return self.delta_seam != 0

    @property
    def evaluations(self) -> int:
        return int(self._native.evaluations)

    @property
    def segments(self) -> np.ndarray:
        return np.asarray(self._native.segments)

    @property
    def ratios(self) -> np.ndarray:
        return np.asarray(self._native.ratios)

    def evaluate(self, theta):
        """-> (value, gradient (n_theta, 2)); a DeviceArray theta gives a DeviceArray gradient."""
        if is_device(theta):
            if self._gpu is None:
                v, g = self._native.evaluate(host(theta))
                return v, self._out.put("grad", g)
            g = self._out.get("grad", theta.shape[0], 2)
            return self._gpu.evaluate_device(theta, g), g
        theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, 2)
        return (self._native if self._gpu is None else self._gpu).evaluate(theta)

    def residuals(self, theta) -> np.ndarray:
        """Per segment |a segment| - rho |b segment| (m)."""
        return np.asarray(self._native.residuals(np.asarray(theta, dtype=float).reshape(-1, 2)))

    def gauss_newton(self, theta=None):
        """delta_seam J^T J at theta (default the base, where it is constant) as scipy CSR."""
        import scipy.sparse as sp

        th = self.param.theta_bar if theta is None else np.asarray(theta, dtype=float).reshape(-1, 2)
        r, c, v, shape = self._native.gauss_newton_triplets(th)
        return sp.csr_matrix((v, (r, c)), shape=shape)
