"""Parametrization, regularizers, preconditioner and fitting costs: values against
independent numpy formulas, gradients against central finite differences."""
import numpy as np
import pytest

import opt_synthetic as S
from seamfit.errors import PatternError, SolveError
from seamfit.opt import (CORNER_WEIGHT, CostSet, Parametrization, Regularizers, Strengths,
                         positional_weights, sample_sdf)
from seamfit.opt.costs import COST_TERM_NAMES


@pytest.fixture(scope="module")
def mesh():
    return S.two_panels()


def fd_check(f, grad, x0, rng, n_dirs=6, eps=1e-6, rtol=2e-6):
    """Directional derivatives of f at x0 (central differences) against grad . d."""
    worst = 0.0
    for _ in range(n_dirs):
        d = rng.normal(size=x0.shape)
        d /= np.linalg.norm(d)
        fd = (f(x0 + eps * d) - f(x0 - eps * d)) / (2 * eps)
        an = float(np.sum(grad * d))
        err = abs(fd - an) / max(abs(an), abs(fd), 1e-12)
        worst = max(worst, err)
    assert worst < rtol, f"finite-difference mismatch, worst relative error {worst:.3e}"
    return worst


def rot(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


# ---------------------------------------------------------------- parametrization

def test_base_parameters_give_base_pattern(param):
    assert np.abs(param.pattern(param.theta_bar) - param.pbar).max() < 1e-15
    assert param.n_theta == int(np.sum(param.arrays.boundary))


def test_affine_boundary_motion_moves_interior_affinely(mesh, param):
    vp = mesh.vertex_panel
    maps = {0: (1.0 * rot(0.6), np.array([0.3, -0.1])),            # rigid
            1: (1.3 * rot(-0.2), np.array([-0.05, 0.2]))}           # similarity
    shear = np.array([[1.2, 0.3], [-0.1, 0.8]])                     # general affine
    for panel_maps in (maps, {0: (shear, np.zeros(2)), 1: maps[0]}):
        want = np.empty_like(param.pbar)
        for k, (a, t) in panel_maps.items():
            want[vp == k] = param.pbar[vp == k] @ a.T + t
        p = param.pattern(param.theta_of(want))
        assert np.abs(p - want).max() < 1e-12


def test_laplacian_symmetric_and_interior_block_spd():
    m = S.two_panels(seed=3)                     # jittered: some obtuse angles
    P = Parametrization(m)
    L = P.laplacian().toarray()
    assert np.abs(L - L.T).max() < 1e-12
    assert np.abs(L.sum(1)).max() < 1e-12
    off = L - np.diag(np.diag(L))
    assert (off > 1e-12).any(), "expected some negative cotangent weights with this jitter"
    LI = L[np.ix_(P.interior_ids, P.interior_ids)]
    assert np.linalg.eigvalsh(LI).min() > 0
    # Interior rows annihilate the rest coordinates (affine reproduction).
    assert np.abs(L[P.interior_ids] @ P.pbar).max() < 1e-12


def test_parametrization_adjoint_matches_finite_differences(param):
    rng = np.random.default_rng(4)
    g = rng.normal(size=param.pbar.shape)
    f = lambda th: float(np.sum(g * param.pattern(th)))
    th0 = param.theta_bar + rng.normal(0, 0.01, param.theta_bar.shape)
    fd_check(f, param.adjoint(g), th0, rng)


def test_harmonic_blocks_reproduce_the_interior_update():
    """The dense per-panel blocks the GPU applies: p^I = pbar^I + M_k (theta - theta_bar)
    on each panel equals the sparse Cholesky update, and the blocks are panel-sized."""
    m = S.two_panels(seed=3)
    P = Parametrization(m)
    blocks = P._native.harmonic_blocks()
    assert len(blocks) == len(np.unique(m.vertex_panel))
    assert sum(len(r) * len(c) for r, c, _ in blocks) == P._native.harmonic_doubles
    rng = np.random.default_rng(8)
    theta = P.theta_bar + rng.normal(0, 0.01, P.theta_bar.shape)
    want = P.pattern(theta)
    got = np.array(P.pbar)
    got[P.boundary_ids] = theta
    for rows, cols, M in blocks:
        got[P.interior_ids[rows]] = P.pbar[P.interior_ids[rows]] + M @ (theta - P.theta_bar)[cols]
        assert len(np.unique(m.vertex_panel[P.boundary_ids[cols]])) == 1   # one panel per block
    assert np.abs(got - want).max() < 1e-14


def test_vertex_without_triangle_is_rejected(mesh):
    bad = S.two_panels()
    bad.uv_cm = np.vstack([bad.uv_cm, [[5.0, 5.0]]])
    bad.boundary = np.append(bad.boundary, False)
    bad.corner = np.append(bad.corner, False)
    with pytest.raises(PatternError, match="no triangle"):
        Parametrization(bad)


# ---------------------------------------------------------------- regularizers

def reference_rcur(theta, theta_bar, loops, w, delta):
    """Eq. 10 with T_i = the similarity mapping the base chord to the current chord."""
    z = theta[:, 0] + 1j * theta[:, 1]
    zb = theta_bar[:, 0] + 1j * theta_bar[:, 1]
    total = 0.0
    for lp in loops:
        lp = np.asarray(lp)
        j, k = np.roll(lp, 1), np.roll(lp, -1)
        d, db = z[j] + z[k] - 2 * z[lp], zb[j] + zb[k] - 2 * zb[lp]
        T = (z[k] - z[j]) / (zb[k] - zb[j])
        total += 0.5 * delta * np.sum(w[lp] * np.abs(d - T * db) ** 2)
    return total


def theta_loops(param):
    return [param.theta_index[lp] for lp in param.arrays.loops]


def test_regularizer_values_and_gradient(mesh, param):
    rng = np.random.default_rng(5)
    regs = Regularizers(param, delta_fix=100.0, delta_cur=1e6)
    th = param.theta_bar + rng.normal(0, 0.005, param.theta_bar.shape)
    v, terms, g = regs.evaluate(th)
    assert terms["fix"] == pytest.approx(50.0 * np.sum((th - param.theta_bar) ** 2), rel=1e-12)
    assert terms["cur"] == pytest.approx(
        reference_rcur(th, param.theta_bar, theta_loops(param), regs.weight, 1e6), rel=1e-10)
    assert v == pytest.approx(terms["fix"] + terms["cur"], rel=1e-14)
    fd_check(lambda t: regs.evaluate(t)[0], g, th, rng)


def test_corners_weigh_less(param):
    corner = param.arrays.corner[param.boundary_ids]
    assert corner.sum() == 8
    regs = Regularizers(param, 1.0, 1.0)
    assert np.all(regs.weight[corner] == CORNER_WEIGHT) and np.all(regs.weight[~corner] == 1.0)
    assert CORNER_WEIGHT < 1.0


def test_curve_term_ignores_similarity_per_panel(mesh, param):
    regs = Regularizers(param, delta_fix=0.0, delta_cur=1e6)
    vp = mesh.vertex_panel[param.boundary_ids]
    th = param.theta_bar.copy()
    th[vp == 0] = 0.7 * th[vp == 0] @ rot(1.1).T + [0.2, 0.3]
    th[vp == 1] = 1.4 * th[vp == 1] @ rot(-0.4).T - [0.1, 0.0]
    assert regs.evaluate(th)[1]["cur"] < 1e-18
    # ... but not a non-uniform stretch.
    th2 = param.theta_bar * [1.1, 1.0]
    assert regs.evaluate(th2)[1]["cur"] > 1e-3


def test_preconditioner_is_the_regularizer_hessian(param):
    rng = np.random.default_rng(6)
    regs = Regularizers(param, delta_fix=100.0, delta_cur=1e6)
    H = regs.hessian().toarray()
    assert np.abs(H - H.T).max() < 1e-6
    assert np.linalg.eigvalsh(H).min() >= 100.0 * (1 - 1e-9)   # delta_fix I + PSD
    th = param.theta_bar + rng.normal(0, 0.01, param.theta_bar.shape)
    d = rng.normal(0, 0.01, th.shape)
    # R is quadratic: its gradient changes by exactly H d.
    dg = regs.evaluate(th + d)[2] - regs.evaluate(th)[2]
    assert np.abs(dg.ravel() - H @ d.ravel()).max() < 1e-7 * np.abs(dg).max()
    v = rng.normal(size=th.shape)
    assert np.abs(regs.apply_preconditioner((H @ v.ravel()).reshape(-1, 2)) - v).max() < 1e-8
    regs.set_strengths(0.0, 1e6)
    with pytest.raises(ValueError, match="delta_fix"):
        regs.apply_preconditioner(v)


# ---------------------------------------------------------------- costs

@pytest.fixture(scope="module")
def garment(mesh):
    xbar = S.wrapped_garment(mesh)
    rng = np.random.default_rng(7)
    x = 1.05 * xbar + rng.normal(0, 2e-3, xbar.shape) + [0.01, 0.0, -0.02]
    # Grid origin off any round multiple of the spacing, so no vertex sits on a cell face
    # (where the trilinear interpolant has a kink).
    lo, hi = np.minimum(xbar, x).min(0) - 0.0537, np.maximum(xbar, x).max(0) + 0.05
    sdf = S.sphere_sdf([0.0, 0.0, 0.9], 0.15, lo, hi, 0.0093)
    base_sdf = S.sphere_sdf([0.0, 0.01, 0.9], 0.14, lo, hi, 0.0093)
    xtilde = xbar + rng.normal(0, 0.01, xbar.shape)
    return dict(xbar=xbar, x=x, sdf=sdf, base_sdf=base_sdf, xtilde=xtilde)


def make_costs(mesh, garment, **strengths):
    return CostSet(mesh, garment["xbar"], Strengths(**strengths), target_sdf=garment["sdf"],
                   base_sdf=garment["base_sdf"], xtilde=garment["xtilde"])


def check_term(mesh, param, garment, name, delta, reference, eps=1e-6, rtol=2e-6):
    rng = np.random.default_rng(sum(map(ord, name)))   # deterministic per term
    cs = make_costs(mesh, garment, **{name: delta})
    x = garment["x"]
    p = param.pbar * 1.02 + rng.normal(0, 1e-3, param.pbar.shape)
    v, terms, gx, gp = cs.evaluate(x, p)
    assert v == pytest.approx(terms[name], rel=1e-14)
    assert all(terms[k] == 0 for k in terms if k != name)
    if reference is not None:
        assert v == pytest.approx(reference(x, p), rel=1e-10)
    fd_check(lambda xx: cs.evaluate(xx, p)[0], gx, x, rng, eps=eps, rtol=rtol)
    if np.abs(gp).max() > 0:
        fd_check(lambda pp: cs.evaluate(x, pp)[0], gp, p, rng, eps=eps, rtol=rtol)
    return cs, gx, gp


def test_distance_cost(mesh, param, garment):
    phibar = sample_sdf(garment["base_sdf"], garment["xbar"])[0]
    ref = lambda x, p: 0.5 * 3.0 * np.sum((sample_sdf(garment["sdf"], x)[0] - phibar) ** 2)
    # The trilinear interpolant is only C0 across grid cells: a small step keeps the
    # central differences inside the cells.
    _, _, gp = check_term(mesh, param, garment, "dis", 3.0, ref, eps=1e-8, rtol=1e-5)
    assert np.all(gp == 0)
    # The analytic sphere: grid values agree with the exact distance (trilinear error only).
    x = garment["x"]
    exact = np.linalg.norm(x - [0.0, 0.0, 0.9], axis=1) - 0.15
    assert np.abs(sample_sdf(garment["sdf"], x)[0] - exact).max() < 2e-3


def test_positional_cost(mesh, param, garment):
    u = positional_weights(mesh)
    assert set(np.unique(u)) == {1.0, 4.0} and np.all(u[mesh.boundary] == 4.0)
    ref = lambda x, p: 0.5 * 7.0 * np.sum(u * np.sum((x - garment["xtilde"]) ** 2, 1))
    _, _, gp = check_term(mesh, param, garment, "pos", 7.0, ref)
    assert np.all(gp == 0)


def test_stretching_cost(mesh, param, garment):
    xbar = garment["xbar"]
    cs = make_costs(mesh, garment, str=1.0)
    e = cs.edges
    assert len(e) == len({tuple(sorted(t)) for t in e})  # each undirected edge once
    rbar = np.linalg.norm(xbar[e[:, 0]] - xbar[e[:, 1]], axis=1) / np.linalg.norm(
        param.pbar[e[:, 0]] - param.pbar[e[:, 1]], axis=1)

    def ref(x, p):
        r = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1) / np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
        return 0.5 * 2.0 * np.sum((r - rbar) ** 2)

    _, _, gp = check_term(mesh, param, garment, "str", 2.0, ref)
    assert np.abs(gp).max() > 0
    # Zero at the base state, and for a garment scaled with its pattern.
    assert cs.evaluate(xbar, param.pbar)[0] == 0.0
    assert cs.evaluate(1.3 * xbar, 1.3 * param.pbar)[0] < 1e-25


def test_smoothness_cost(mesh, param, garment):
    cs, _, gp = check_term(mesh, param, garment, "smo", 0.5, None)
    assert np.all(gp == 0)
    w, h = cs.hinge_weights, cs.hinges
    # Kernel from the base pattern annihilates it and any affine image of it.
    assert np.abs(w.sum(1)).max() < 1e-9
    assert np.abs(np.einsum("ha,had->hd", w, param.pbar[h])).max() < 1e-9
    A = np.array([[0.9, 0.2], [0.1, 1.1], [0.3, -0.4]])
    flat = param.pbar @ A.T + [0.1, 0.2, 0.3]
    zero = CostSet(mesh, flat, Strengths(smo=1.0))
    assert zero.evaluate(flat @ np.diag([1.0, 1.0, 1.0]), param.pbar)[0] < 1e-25
    # At the base garment the cost vanishes; the base garment is curved (nonzero |L xbar|).
    assert cs.evaluate(garment["xbar"], param.pbar)[0] < 1e-25
    assert np.abs(np.einsum("ha,had->hd", w, garment["xbar"][h])).max() > 1e-3


def one_hinge(fold):
    """Two triangles sharing edge 0-1 (unit square split along a diagonal), folded."""
    uv = np.array([[0, 0], [1, 0], [0.3, 0.8], [0.6, -0.7]]) * 10.0
    tris = np.array([[0, 1, 2], [1, 0, 3]], np.int32)
    p = uv / 100.0
    # Rotate vertex 3 about the edge (the x axis) by `fold`.
    x = np.zeros((4, 3))
    x[:, :2] = p
    x[3] = [p[3, 0], p[3, 1] * np.cos(fold), p[3, 1] * np.sin(fold)]
    from types import SimpleNamespace
    m = SimpleNamespace(uv_cm=uv, triangles=tris, boundary=np.ones(4, bool), corner=np.zeros(4, bool),
                        boundary_loops=[np.array([0, 3, 1, 2])])
    return m, x, p


def test_smoothness_measures_bending_angle_and_side():
    theta = 0.5
    m, xb, p = one_hinge(theta)
    cs = CostSet(m, xb, Strengths(smo=2.0))
    w = cs.hinge_weights[0]
    h = cs.hinges[0]
    # Isometric fold: |L_e x| = 2 sin(theta / 2).
    assert np.linalg.norm(w @ xb[h]) == pytest.approx(2 * np.sin(theta / 2), rel=1e-12)
    # Same side, other angle: (|Lx| - |Lxbar|)^2; opposite side: (|Lx| + |Lxbar|)^2 (s_e = -1).
    _, x_same, _ = one_hinge(0.3)
    _, x_opp, _ = one_hinge(-0.3)
    same = 0.5 * 2.0 * (2 * np.sin(0.15) - 2 * np.sin(0.25)) ** 2
    opp = 0.5 * 2.0 * (2 * np.sin(0.15) + 2 * np.sin(0.25)) ** 2
    assert cs.evaluate(x_same, p)[0] == pytest.approx(same, rel=1e-10)
    assert cs.evaluate(x_opp, p)[0] == pytest.approx(opp, rel=1e-10)


def test_sliver_hinges_carry_no_smoothness():
    m, xb, p = one_hinge(0.5)
    assert len(CostSet(m, xb, Strengths(smo=1.0)).hinges) == 1
    m.uv_cm = m.uv_cm.copy()
    m.uv_cm[3] = [6.0, -1e-6]          # opposite vertex almost on the hinge edge
    assert len(CostSet(m, xb, Strengths(smo=1.0)).hinges) == 0


def test_zero_strength_terms_are_never_evaluated(mesh, param, garment):
    # No SDF and no transferred garment: those terms must not be touched.
    cs = CostSet(mesh, garment["xbar"], Strengths(str=1.0, smo=0.1))
    for _ in range(3):
        v, terms, gx, gp = cs.evaluate(garment["x"], param.pbar)
    assert cs.evaluations == {**dict.fromkeys(COST_TERM_NAMES, 0), "smo": 3, "str": 3}
    assert all(terms[k] == 0 for k in COST_TERM_NAMES if k not in ("smo", "str"))
    none = CostSet(mesh, garment["xbar"], Strengths())
    v, _, gx, gp = none.evaluate(garment["x"], param.pbar)
    assert v == 0 and not gx.any() and not gp.any()
    assert none.evaluations == dict.fromkeys(COST_TERM_NAMES, 0)
    with pytest.raises(SolveError, match="SDF"):
        CostSet(mesh, garment["xbar"], Strengths(dis=1.0))
    with pytest.raises(SolveError, match="xtilde"):
        CostSet(mesh, garment["xbar"], Strengths(pos=1.0))


def test_total_gradient_through_theta(mesh, param, garment):
    """d/dtheta [C(x, p(theta)) + R(theta)] = (dp/dtheta)^T dC/dp + dR/dtheta."""
    rng = np.random.default_rng(8)
    s = Strengths(fix=100, cur=1e4, dis=1, smo=0.05, str=1, pos=100)
    cs = make_costs(mesh, garment, dis=s.dis, smo=s.smo, str=s.str, pos=s.pos)
    regs = Regularizers(param, s.fix, s.cur)
    x = garment["x"]

    def f(th):
        return cs.evaluate(x, param.pattern(th))[0] + regs.evaluate(th)[0]

    th = param.theta_bar * 1.03 + rng.normal(0, 1e-3, param.theta_bar.shape)
    g = param.adjoint(cs.evaluate(x, param.pattern(th))[3]) + regs.evaluate(th)[2]
    fd_check(f, g, th, rng)


def test_fix_in_the_preconditioner_only(param):
    # objective_fix=0: f holds R^cur alone (gradient checked), P keeps delta_fix I.
    rng = np.random.default_rng(7)
    full = Regularizers(param, delta_fix=100.0, delta_cur=1e6)
    regs = Regularizers(param, delta_fix=100.0, delta_cur=1e6, objective_fix=0.0)
    th = param.theta_bar + rng.normal(0, 0.005, param.theta_bar.shape)
    v, terms, g = regs.evaluate(th)
    assert terms["fix"] == 0.0
    assert v == pytest.approx(full.evaluate(th)[1]["cur"], rel=1e-14)
    fd_check(lambda t: regs.evaluate(t)[0], g, th, rng)
    assert np.abs(regs.hessian().toarray() - full.hessian().toarray()).max() == 0.0
    u = rng.normal(size=th.shape)
    assert np.array_equal(regs.apply_preconditioner(u), full.apply_preconditioner(u))
    with pytest.raises(ValueError, match="objective_fix"):
        full.set_strengths(100.0, 1e6, objective_fix=0.0)
