"""The GPU adjoint's MINRES recurrence (native/core/sim/minres.hpp), run on the CPU by
seamfit._core.minres_solve over an assembled H: it solves the shifted, indefinite tangent
system like the direct solve, its residual falls monotonically with the budget, it warm-
starts, and it reports the budget and a preconditioner that is not positive definite."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from seamfit._native import core
from test_tangent_solver import hanging, shifted


def psd_block_inverses(sim, x, shift):
    """Inverses of the PSD 3x3 diagonal blocks (+ the shift), as (n, 6): xx yy zz xy xz yz."""
    Hp = sim.hessian(x, psd=True).tocsr()
    n = Hp.shape[0] // 3
    s = shift * np.mean(np.abs(sim.hessian(x).diagonal()))
    B = np.array([Hp[3 * i:3 * i + 3, 3 * i:3 * i + 3].toarray() for i in range(n)]) + s * np.eye(3)
    Bi = np.linalg.inv(B)
    return np.c_[Bi[:, 0, 0], Bi[:, 1, 1], Bi[:, 2, 2], Bi[:, 0, 1], Bi[:, 0, 2], Bi[:, 1, 2]]


def solve(A, minv, g, lam0=None, tol=1e-10, max_it=20000):
    A = sp.csr_matrix(A)
    lam0 = np.zeros_like(g) if lam0 is None else lam0
    return core().minres_solve(A.indptr.astype(np.int32), A.indices.astype(np.int32), A.data, minv, g, lam0,
                               tol, max_it)


# This garment has three free modes (eigenvalues of H below 1e-16 of its scale); the
# shift 1e-6 keeps their share of the solution small enough that the residual MINRES
# estimates is the one it attains. With the production shift 1e-8 the solution is still
# right (test below), but the attainable residual is 1e-3 (rounding times the size of
# the free modes' share).
SHIFT = 1e-6


@pytest.fixture(scope="module")
def system():
    sim, x = hanging()
    A = shifted(sim, x, SHIFT)
    # Part-way to equilibrium, compressed springs make H indefinite: MINRES, not CG.
    w = spla.eigsh(A, k=1, which="SA", return_eigenvectors=False)
    assert w[0] < 0
    g = np.random.default_rng(3).standard_normal(A.shape[0])
    return A, psd_block_inverses(sim, x, SHIFT), g


def test_minres_solves_the_indefinite_shifted_system(system):
    A, minv, g = system
    lam, rep = solve(A, minv, g)
    assert rep["status"] == "converged" and rep["estimate"] <= 1e-10
    direct = spla.spsolve(sp.csc_matrix(A), g)
    assert rep["residual"] == pytest.approx(np.linalg.norm(A @ lam - g) / np.linalg.norm(g), rel=1e-6, abs=1e-14)
    assert rep["residual"] <= 1e-5
    assert np.linalg.norm(lam - direct) <= 1e-8 * np.linalg.norm(direct)


def test_with_the_production_shift_the_solution_is_still_the_direct_one():
    sim, x = hanging()
    A = shifted(sim, x, 1e-8)
    g = np.random.default_rng(3).standard_normal(A.shape[0])
    lam, rep = solve(A, psd_block_inverses(sim, x, 1e-8), g)
    assert rep["status"] == "converged"
    direct = spla.spsolve(sp.csc_matrix(A), g)
    assert np.linalg.norm(lam - direct) <= 1e-6 * np.linalg.norm(direct)


def test_residual_falls_with_the_budget_and_the_budget_is_reported(system):
    """MINRES minimizes the residual over a growing Krylov space: more iterations never
    leave a larger (preconditioned) residual."""
    A, minv, g = system
    estimates = []
    for k in (5, 20, 80, 320):
        _, rep = solve(A, minv, g, tol=0.0, max_it=k)
        assert rep["status"] == "budget" and rep["iterations"] == k
        estimates.append(rep["estimate"])
    assert all(b <= a * (1 + 1e-12) for a, b in zip(estimates, estimates[1:]))
    assert estimates[-1] < 0.5 * estimates[0]


def test_warm_start_from_the_solution_stops_at_once(system):
    A, minv, g = system
    lam, _ = solve(A, minv, g)
    lam2, rep = solve(A, minv, g, lam0=lam, tol=1e-6)
    assert rep["status"] == "converged" and rep["iterations"] == 0
    assert np.array_equal(lam2, lam)


def test_a_preconditioner_that_is_not_positive_definite_is_a_breakdown(system):
    A, minv, g = system
    _, rep = solve(A, -minv, g)
    assert rep["status"] == "breakdown"
    with pytest.raises(Exception, match="minv must have shape"):
        solve(A, minv[:-1], g)
