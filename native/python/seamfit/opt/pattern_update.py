"""The pattern update of the fixed-point baseline (after the idea of Bartle et al. 2016,
"Physics-driven pattern adjustment for direct 3D garment editing").

Per triangle, with D_p its current 2D pattern edges, S its simulated 3D edges and T its
edges in the target garment x-tilde (S and T written in their own planes, 2x2):

    F   = S D_p^-1                  how the simulation deforms the pattern triangle
    D_p' = F^-1 R T = D_p S^-1 R T  the pattern triangle that F would carry onto T

R is the in-plane rotation that best aligns T with S (2D Procrustes), so only shape
differences move the pattern. If the fabric kept its deformation F when its rest
shape changes, draping D_p' would give the target triangle: a fixed point of the
update is a pattern whose drape is x-tilde (the inverse problem, paper Eq. 3).

The triangles' wishes disagree, so the new pattern is their least-squares
compromise over all three edges of every triangle (a Poisson solve), constrained to patterns the parametrization can represent (interior vertices
harmonic in the boundary, Eq. 8: L_I p = 0). A tiny pull towards the current
pattern fixes the translation of each panel, which no edge sees.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolveError
from .costs import positional_weights

TRANSLATION_PULL = 1e-8   # relative to the mean diagonal; pins a panel's position when nothing else does
DEGENERATE = 1e-12        # m^2: triangles flatter than this keep their pattern shape


def _in_plane(e0: np.ndarray, e1: np.ndarray) -> np.ndarray:
    """(T, 2, 2) edge matrices [e0 e1] of 3D triangles, each in its own orthonormal
    frame (e0 along the first axis, so the determinant is twice the area, >= 0)."""
    l0 = np.linalg.norm(e0, axis=1)
    a = np.einsum("ij,ij->i", e1, e0) / np.maximum(l0, 1e-300)
    n = np.cross(e0, e1)
    b = np.linalg.norm(n, axis=1) / np.maximum(l0, 1e-300)
    out = np.zeros((len(e0), 2, 2))
    out[:, 0, 0] = l0
    out[:, 0, 1] = a
    out[:, 1, 1] = b
    return out


def _best_rotation(T: np.ndarray, S: np.ndarray) -> np.ndarray:
    """(T, 2, 2) rotations R minimizing ||R T - S|| per triangle."""
    num = np.sum(T[:, 0, :] * S[:, 1, :] - T[:, 1, :] * S[:, 0, :], axis=1)
    den = np.sum(T[:, 0, :] * S[:, 0, :] + T[:, 1, :] * S[:, 1, :], axis=1)
    ang = np.arctan2(num, den)
    c, s = np.cos(ang), np.sin(ang)
    return np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)


def _factorize_constrained(K, C):
    """Solver of min z^T K z / 2 - b^T z subject to C z = 0 (KKT system, sparse LU)."""
    kkt = sp.bmat([[K, C.T], [C, None]], format="csc")
    try:
        solve = spla.factorized(kkt)
    except RuntimeError as exc:
        raise SolveError(f"the fixed-point pattern update could not be factorized: {exc}") from exc
    n, m = K.shape[0], C.shape[0]
    return lambda b: solve(np.r_[b, np.zeros(m)])[:n]


class FixedPointUpdate:
    """Prefactorizes the update's linear systems once; ``target_pattern`` gives the
    updated pattern of each iteration, in two steps:

    1. p* = the least-squares compromise of the triangles' wished edges (plain sum over
       the three edges of every triangle), a representable pattern;
    2. with ``regs``: the pattern nearest p* in the positional cost's metric moved to
       the pattern, delta_pos sum_i u_i |p_i - p*_i|^2, plus R^fix + R^cur (quadratic,
       constant Hessian P), so the boundary curves keep their design and the balance
       against the regularizers is the one of the grading objective.
    """

    def __init__(self, mesh, param, delta_pos: float, regs=None, positional_weight=None):
        tri = np.asarray(mesh.triangles, dtype=np.int64)
        n = len(param.pbar)
        self.tri, self.param, self.regs, self.delta = tri, param, regs, float(delta_pos)
        # edges (i->j), (i->k), (j->k) of every triangle
        a, b = np.r_[tri[:, 0], tri[:, 0], tri[:, 1]], np.r_[tri[:, 1], tri[:, 2], tri[:, 2]]
        m = len(a)
        self.E = sp.csr_matrix((np.r_[-np.ones(m), np.ones(m)], (np.r_[np.arange(m), np.arange(m)], np.r_[a, b])),
                               shape=(m, n))
        K = (self.E.T @ self.E).tocsr()
        self.pull = TRANSLATION_PULL * float(np.mean(K.diagonal()))
        C = param.laplacian().tocsr()[np.asarray(param.interior_ids, dtype=np.int64), :]
        self._poisson = _factorize_constrained(K + self.pull * sp.identity(n, format="csr"), C)
        if regs is not None:
            # unknowns: the pattern flattened (x0, y0, x1, y1, ...), as theta is (R couples x and y)
            I2 = sp.identity(2, format="csr")
            nb = param.n_theta
            self.B = sp.kron(sp.csr_matrix((np.ones(nb), (np.arange(nb), param.boundary_ids)), shape=(nb, n)),
                             I2, format="csr")
            self.P = regs.hessian(extra=False)   # R^fix + R^cur, the terms regs.evaluate gives
            u = positional_weights(mesh) if positional_weight is None else np.asarray(positional_weight, float)
            self.u2 = np.repeat(u, 2)
            K2 = sp.diags(2.0 * self.delta * self.u2) + self.B.T @ self.P @ self.B
            self._project = _factorize_constrained(K2.tocsr(), sp.kron(C, I2, format="csr"))

    def triangle_targets(self, p, x, xtilde) -> np.ndarray:
        """(T, 2, 2) wished pattern edges D_p' = D_p S^-1 R T of every triangle."""
        t = self.tri
        Dp = np.stack([p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]], axis=2)
        S = _in_plane(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]])
        T = _in_plane(xtilde[t[:, 1]] - xtilde[t[:, 0]], xtilde[t[:, 2]] - xtilde[t[:, 0]])
        detS = S[:, 0, 0] * S[:, 1, 1]
        detT = T[:, 0, 0] * T[:, 1, 1]
        ok = (detS > DEGENERATE) & (detT > DEGENERATE)
        M = np.tile(np.eye(2), (len(t), 1, 1))
        R = _best_rotation(T[ok], S[ok])
        M[ok] = np.linalg.solve(S[ok], R @ T[ok])
        return Dp @ M

    def poisson(self, p, x, xtilde) -> np.ndarray:
        """Step 1: the pattern (N, 2) m whose edges best match the triangles' wishes."""
        p = np.asarray(p, dtype=float)
        D = self.triangle_targets(p, np.asarray(x, float), np.asarray(xtilde, float))
        d = np.concatenate([D[:, :, 0], D[:, :, 1], D[:, :, 1] - D[:, :, 0]])   # (3T, 2), rows as in E
        rhs = self.E.T @ d + self.pull * p
        return np.stack([self._poisson(rhs[:, c]) for c in range(2)], axis=1)

    def target_pattern(self, p, x, xtilde) -> np.ndarray:
        """The updated pattern (N, 2) m."""
        p_star = self.poisson(p, x, xtilde)
        if self.regs is None:
            return p_star
        theta = self.param.theta_of(p)
        g0 = self.regs.evaluate(theta)[2].reshape(-1) - self.P @ theta.reshape(-1)   # R's linear part
        rhs = 2.0 * self.delta * self.u2 * p_star.reshape(-1) - self.B.T @ g0
        return self._project(rhs).reshape(-1, 2)
