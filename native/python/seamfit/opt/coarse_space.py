"""The coarse space of the GPU adjoint's two-level preconditioner (docs/gpu.md, "A coarse
space for MINRES").

Block-Jacobi MINRES removes the short wavelengths of the residual within a few
iterations and the longest ones (a whole region of the garment sliding or turning on the
body) only over thousands, and their count grows with the mesh. The additive two-level
preconditioner M^-1 = D^-1 + P A_c^-1 P^T adds a correction over a few hundred aggregates
of vertices, three translations each: P is piecewise constant, A_c = P^T H_psd P is the
PSD-projected tangent stiffness seen by those translations (symmetric positive definite,
so M stays a valid MINRES preconditioner), and its dense inverse lives on the GPU.

Aggregates are boxes of the garment's own state: a cubic grid whose cell is chosen so
that a surface of the garment's area falls into about `target` cells. They depend on the
mesh's size through its area only, so the coarse problem keeps its size as the mesh is
refined.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import SolveError

# Aggregates aimed at: the coarse matrix is (3 n)^2 doubles, 19 MiB at 512, and one
# product with it per MINRES iteration reads all of it (a few microseconds on an H100).
COARSE_AGGREGATES = 512


def surface_area(x: np.ndarray, triangles: np.ndarray) -> float:
    """Area (m^2) of the triangle mesh at positions x."""
    a, b, c = (x[triangles[:, k]] for k in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def aggregates(x: np.ndarray, triangles: np.ndarray, target: int = COARSE_AGGREGATES) -> tuple[np.ndarray, int]:
    """Each vertex's aggregate (int32) and the number of aggregates: the cells of a cubic
    grid of spacing sqrt(area / target) that hold a vertex."""
    x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
    if target < 1:
        raise SolveError(f"the coarse space needs at least one aggregate, got {target}")
    area = surface_area(x, np.asarray(triangles))
    if not (np.isfinite(area) and area > 0) or not np.all(np.isfinite(x)):
        raise SolveError("the coarse space needs a garment state with finite positions and a positive area")
    cell = np.sqrt(area / target)
    key = np.floor((x - x.min(axis=0)) / cell).astype(np.int64)
    _, agg = np.unique(key, axis=0, return_inverse=True)
    agg = agg.reshape(-1).astype(np.int32)
    return agg, int(agg.max()) + 1


def prolongation(agg: np.ndarray, n_agg: int) -> sp.csr_matrix:
    """P (3 N x 3 n_agg): vertex i's axis d follows aggregate agg[i]'s axis d."""
    n = len(agg)
    rows = np.arange(3 * n)
    cols = 3 * np.repeat(agg.astype(np.int64), 3) + np.tile(np.arange(3), n)
    return sp.csr_matrix((np.ones(3 * n), (rows, cols)), shape=(3 * n, 3 * n_agg))


def coarse_inverse(H_psd, agg: np.ndarray, n_agg: int, shift_rel: float) -> np.ndarray:
    """Dense (P^T (H_psd + s I) P)^-1, s = shift_rel * mean|diag H_psd| (the adjoint's shift),
    row-major and exactly symmetric."""
    H = sp.csr_matrix(H_psd)
    d = np.abs(H.diagonal())
    s = float(shift_rel) * float(d.mean()) if d.size else 0.0
    P = prolongation(agg, n_agg)
    Ac = (P.T @ (H @ P)).toarray() + s * (P.T @ P).toarray()
    Ac = 0.5 * (Ac + Ac.T)
    try:
        c = sla.cho_factor(Ac, lower=True, check_finite=True)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise SolveError(f"the coarse matrix of the adjoint's preconditioner is not positive definite: {exc}") from exc
    inv = sla.cho_solve(c, np.eye(Ac.shape[0]))
    return np.ascontiguousarray(0.5 * (inv + inv.T))
