"""The coarse space of the GPU adjoint's two-level preconditioner (seamfit.opt.coarse_space):
aggregates that partition the garment, the Galerkin coarse matrix and its inverse, and,
with SciPy's MINRES on the CPU, that block Jacobi plus the coarse correction solves the
adjoint system of a real grading state in fewer iterations than block Jacobi alone."""
from __future__ import annotations


import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from seamfit.errors import SolveError
from seamfit.opt.coarse_space import aggregates, coarse_inverse, prolongation, surface_area



def grid_sheet(n: int, size: float = 1.0):
    """An n x n vertex sheet in the z = 0 plane, two triangles per cell."""
    u = np.linspace(0, size, n)
    X, Y = np.meshgrid(u, u, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), np.zeros(n * n)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return x, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_aggregates_partition_the_vertices_into_about_the_target_count():
    x, tri = grid_sheet(41, 2.0)
    assert surface_area(x, tri) == pytest.approx(4.0)
    for target in (16, 64, 256):
        agg, n = aggregates(x, tri, target)
        assert agg.dtype == np.int32 and agg.shape == (len(x),)
        assert set(np.unique(agg)) == set(range(n))          # every aggregate holds a vertex
        assert 0.5 * target <= n <= 2.0 * target, (target, n)
    # The same garment at another scale gets the same aggregates (a power of two: exact arithmetic).
    agg1, n1 = aggregates(x, tri, 64)
    agg2, n2 = aggregates(0.25 * x, tri, 64)
    assert n1 == n2 and np.array_equal(agg1, agg2)


def test_aggregates_refuse_a_degenerate_state():
    x, tri = grid_sheet(5)
    with pytest.raises(SolveError, match="positive area"):
        aggregates(np.zeros_like(x), tri, 8)
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(SolveError, match="finite"):
        aggregates(bad, tri, 8)
    with pytest.raises(SolveError, match="at least one"):
        aggregates(x, tri, 0)


def test_coarse_inverse_is_the_inverse_of_the_galerkin_matrix():
    rng = np.random.default_rng(4)
    n = 30
    A = sp.random(3 * n, 3 * n, density=0.1, random_state=5)
    H = (A @ A.T + sp.identity(3 * n)).tocsr()
    agg = rng.integers(0, 7, n).astype(np.int32)
    agg[:7] = np.arange(7)
    P = prolongation(agg, 7)
    assert P.shape == (3 * n, 21) and np.allclose(P.sum(axis=1), 1.0)
    shift_rel = 1e-3
    s = shift_rel * np.mean(np.abs(H.diagonal()))
    Ac = (P.T @ (H + s * sp.identity(3 * n)) @ P).toarray()
    inv = coarse_inverse(H, agg, 7, shift_rel)
    assert np.allclose(inv, inv.T, rtol=0, atol=0)
    assert np.allclose(inv @ Ac, np.eye(21), atol=1e-10)
    with pytest.raises(SolveError, match="not positive definite"):
        coarse_inverse(-H, agg, 7, 0.0)


def test_two_level_preconditioner_needs_fewer_minres_iterations_than_block_jacobi():
    """MINRES on H lam = dF/dx at a settled grading state (the pencil skirt on the size 10
    body), from the PSD diagonal blocks alone and with the coarse correction added."""
    from grading_helpers import settled_sample_grading

    ctx, x = settled_sample_grading(2.0, "cpu")
    _, _, gx, _ = ctx.costs.evaluate(x, ctx.param.pattern(ctx.param.theta_bar))
    g = np.asarray(gx, dtype=float).reshape(-1)
    H = ctx.sim.hessian(x).tocsr()
    Hp = ctx.sim.hessian(x, psd=True).tocsr()
    shift_rel = 1e-8
    n3 = H.shape[0]
    H = H + shift_rel * np.mean(np.abs(H.diagonal())) * sp.identity(n3)
    blocks = np.stack([np.stack([Hp[np.arange(0, n3, 3) + a, np.arange(0, n3, 3) + b].A1 for b in range(3)], -1)
                       for a in range(3)], 1)
    blocks = blocks + shift_rel * np.mean(np.abs(Hp.diagonal())) * np.eye(3)
    binv = np.linalg.inv(blocks)

    def jacobi(r):
        return np.einsum("nab,nb->na", binv, r.reshape(-1, 3)).reshape(-1)

    agg, n_agg = aggregates(x, ctx.mesh.triangles, 64)
    P = prolongation(agg, n_agg)
    inv = coarse_inverse(Hp, agg, n_agg, shift_rel)

    def two_level(r):
        return jacobi(r) + P @ (inv @ (P.T @ r))

    counts = {}
    for name, M in (("jacobi", jacobi), ("two-level", two_level)):
        it = [0]
        lam, info = spla.minres(H, g, M=spla.LinearOperator(H.shape, M), rtol=1e-10, maxiter=20000,
                                callback=lambda _: it.__setitem__(0, it[0] + 1))
        assert info == 0
        assert np.linalg.norm(H @ lam - g) <= 1e-4 * np.linalg.norm(g)
        counts[name] = it[0]
    print(counts)
    assert counts["two-level"] < 0.8 * counts["jacobi"], counts
