"""The adjoint's linear solves with the tangent stiffness H (seamfit._core.TangentSolver:
sparse LDL^T, AMD ordering analysed once): they solve (H + shift) lambda = g, agree with
SuperLU's pivoting LU, report a vanishing pivot instead of returning garbage, and the
AdjointSolver falls back to the LU there."""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from opt_synthetic import two_panels
from seamfit._native import core
from seamfit.opt.adjoint import AdjointSolver
from seamfit.sim.model import Fabric, SimSettings, Simulator


def hanging(pinned=True):
    mesh = two_panels(seed=5, jitter=0.2, scale=0.5)
    p = mesh.uv_cm / 100.0
    mesh.x0 = np.c_[p[:, 0], np.zeros(len(p)), 1.0 + p[:, 1]]
    sim = Simulator(mesh, None, Fabric(stretch_stiffness=50.0, bending_stiffness=1e-6), SimSettings())
    if pinned:
        top = np.flatnonzero(mesh.boundary & (p[:, 1] >= p[:, 1].max() - 1e-9))
        sim.set_sticking(top, mesh.x0[top], stiffness=200.0)
    # Part-way to equilibrium: some springs compressed, so H is indefinite.
    x = sim.solve(mesh.x0, max_iterations=300).x
    return sim, x


def shifted(sim, x, shift, psd=False):
    H = sim.hessian(x, psd=psd).tocsc()
    return H + sp.identity(H.shape[0], format="csc") * shift * np.mean(np.abs(H.diagonal()))


def test_ldlt_solves_the_shifted_tangent_system_like_lu():
    sim, x = hanging()
    g = np.random.default_rng(1).standard_normal(3 * sim.n_vertices)
    t = core().TangentSolver(sim.core)
    assert t.factorize(x, False, 1e-8)
    lam = t.solve(g)
    A = shifted(sim, x, 1e-8)
    assert np.linalg.norm(A @ lam - g) <= 1e-8 * np.linalg.norm(g)
    lu = spla.spsolve(A, g)
    assert np.linalg.norm(lam - lu) <= 1e-6 * np.linalg.norm(lu)
    # a second factorization reuses the analysed pattern and still solves
    assert t.factorize(x, True, 1e-8) and t.factorizations == 2
    assert np.linalg.norm(shifted(sim, x, 1e-8, psd=True) @ t.solve(g) - g) <= 1e-8 * np.linalg.norm(g)


def test_a_free_garment_has_a_vanishing_pivot_and_the_adjoint_falls_back():
    """Unpinned and without a body, the garment can translate freely: H is singular.
    Without a shift the LDL^T says so; the AdjointSolver's default shift pins the free
    modes and its solve is that of the shifted system."""
    sim, x = hanging(pinned=False)
    t = core().TangentSolver(sim.core)
    assert not t.factorize(x, False, 0.0)
    adj = AdjointSolver(sim)
    adj.factorize(x)
    g = np.random.default_rng(2).standard_normal(3 * sim.n_vertices)
    lam = adj.solve(g)
    A = shifted(sim, x, adj.shift)
    assert np.all(np.isfinite(lam))
    assert np.linalg.norm(A @ lam - g) <= 1e-6 * np.linalg.norm(g)
