"""Each energy term of the simulator on its own: value, force (= -gradient),
Hessian and Hessian-vector product, and the pattern-space product (df/dp)^T lambda,
all against central finite differences; plus the physical facts each term must
satisfy (rest states, rigid invariance, the barrier's equilibrium gap)."""
from __future__ import annotations

import numpy as np
import pytest

from seamfit._native import core
from seamfit.errors import SolveError
from seamfit.sim import Fabric, SimSettings, Simulator

from sim_helpers import capsule_sdf, equilateral_sheet, flat_sheet, floor_sdf, sewn_tube, sphere_sdf

TERMS = ("stretch", "sewing", "bending", "gravity", "sticking", "barrier")


def make(mesh, term=None, sdf=None, mu=0.01, **over):
    """A core simulator with only `term` switched on (all terms when None)."""
    pr = core().SimParams()
    on = lambda t: term is None or term == t
    pr.stretch_Y = over.get("Y", 2.0) if on("stretch") else 0.0
    pr.sewing_Y = over.get("Ys", 50.0) if on("sewing") else 0.0
    pr.bend_kb = over.get("kb", 1e-3) if on("bending") else 0.0
    pr.density = 0.2 if (on("gravity") or on("barrier")) else 0.0
    pr.gravity = [0.3, -0.2, -9.81] if on("gravity") else [0.0, 0.0, 0.0]
    pr.mu = mu if on("barrier") else 0.0
    pr.barrier_length = 0.1
    pr.barrier_distance = over.get("dhat", 0.06)  # reaches the test states
    pr.barrier_smooth = over.get("smooth", True)
    sim = core().Simulator(0.01 * mesh.uv_cm, mesh.triangles, mesh.sewing_pairs, pr)
    if sdf is not None:
        sim.set_sdf(sdf.values, sdf.origin, sdf.spacing)
    if on("sticking"):
        rng = np.random.default_rng(5)
        k = np.where(rng.random(sim.n_vertices) < 0.3, 40.0, 0.0)
        sim.set_sticking(k, mesh.x0 + 0.02 * rng.standard_normal(mesh.x0.shape))
    return sim


def perturbed(mesh, scale=0.01, seed=1):
    rng = np.random.default_rng(seed)
    return mesh.x0 + scale * rng.standard_normal(mesh.x0.shape)


def fd_force(sim, x, eps=1e-6):
    g = np.zeros_like(x)
    for i in range(x.shape[0]):
        for a in range(3):
            xp = x.copy(); xp[i, a] += eps
            xm = x.copy(); xm[i, a] -= eps
            g[i, a] = -(sim.energy(xp)[0] - sim.energy(xm)[0]) / (2 * eps)
    return g


def tube_case():
    return sewn_tube(radius_m=0.1, height_cm=12.0, nu=4, nv=3, gap_m=0.03, jitter=0.2)


def body_for(mesh):
    return capsule_sdf(radius=0.1, z_lo=-0.1, z_hi=0.3, spacing=0.01)


@pytest.mark.parametrize("term", TERMS)
def test_force_is_minus_energy_gradient(term):
    mesh = tube_case()
    sdf = body_for(mesh)
    sim = make(mesh, term, sdf)
    x = perturbed(mesh, 0.01)
    assert sim.first_inside if hasattr(sim, "first_inside") else True
    f = sim.force(x)
    g = fd_force(sim, x)
    scale = np.abs(g).max() + 1e-12
    assert scale > 1e-9, f"term {term} has no force at the test state"
    np.testing.assert_allclose(f, g, atol=2e-6 * scale, rtol=1e-5)
    # only this term carries energy
    _, terms = sim.energy(x)
    for t in TERMS:
        if t != term:
            assert terms[t] == 0.0


@pytest.mark.parametrize("term", TERMS)
def test_hessian_matches_force_differences(term):
    mesh = tube_case()
    sim = make(mesh, term, body_for(mesh))
    x = perturbed(mesh, 0.01, seed=2)
    rng = np.random.default_rng(3)
    data, indices, indptr, shape = sim.hessian(x, False)
    import scipy.sparse as sp
    H = sp.csc_matrix((data, indices, indptr), shape=shape)
    assert abs(H - H.T).max() <= 1e-9 * (abs(H).max() + 1e-30), "Hessian must be symmetric"
    for _ in range(3):
        v = rng.standard_normal(x.shape)
        eps = 1e-6
        fd = -(sim.force(x + eps * v) - sim.force(x - eps * v)) / (2 * eps)
        hv = sim.hess_vec(x, v, False)
        scale = np.abs(fd).max() + 1e-12
        np.testing.assert_allclose(hv, fd, atol=2e-6 * scale, rtol=1e-5)
        np.testing.assert_allclose((H @ v.ravel()).reshape(-1, 3), hv, atol=1e-10 * scale, rtol=1e-9)


@pytest.mark.parametrize("term", TERMS)
def test_psd_hessian_is_psd_and_consistent(term):
    mesh = tube_case()
    sim = make(mesh, term, body_for(mesh))
    # Compress the garment so springs are under compression (indefinite exact Hessian).
    x = 0.9 * perturbed(mesh, 0.002, seed=4) + np.array([0.0, 0.0, 0.01])
    import scipy.sparse as sp
    data, indices, indptr, shape = sim.hessian(x, True)
    Hp = sp.csc_matrix((data, indices, indptr), shape=shape).toarray()
    assert np.allclose(Hp, Hp.T, atol=1e-10 * np.abs(Hp).max())
    lam_min = np.linalg.eigvalsh(Hp).min()
    assert lam_min >= -1e-9 * np.abs(Hp).max()
    v = np.random.default_rng(0).standard_normal(x.shape)
    np.testing.assert_allclose(sim.hess_vec(x, v, True).ravel(), Hp @ v.ravel(), rtol=1e-9,
                               atol=1e-10 * np.abs(Hp).max())
    if term == "stretch":
        data, indices, indptr, shape = sim.hessian(x, False)
        He = sp.csc_matrix((data, indices, indptr), shape=shape).toarray()
        assert np.linalg.eigvalsh(He).min() < -1e-6 * np.abs(He).max(), "compression must be indefinite"


@pytest.mark.parametrize("term", ["stretch", "bending", "gravity", "barrier"])
def test_dfdp_product_matches_finite_differences(term):
    mesh = tube_case()
    sdf = body_for(mesh)
    sim = make(mesh, term, sdf)
    x = perturbed(mesh, 0.01, seed=6)
    rng = np.random.default_rng(7)
    lam = rng.standard_normal(x.shape)
    p0 = 0.01 * mesh.uv_cm
    prod = sim.dfdp_T(x, lam)
    assert np.abs(prod).max() > 0
    for _ in range(3):
        dp = rng.standard_normal(p0.shape)
        eps = 1e-7
        sim.set_pattern(p0 + eps * dp)
        fp = np.sum(lam * sim.force(x))
        sim.set_pattern(p0 - eps * dp)
        fm = np.sum(lam * sim.force(x))
        sim.set_pattern(p0)
        fd = (fp - fm) / (2 * eps)
        an = np.sum(prod * dp)
        assert an == pytest.approx(fd, rel=1e-5, abs=1e-7 * np.abs(prod).sum())


def test_dfdp_all_terms_together_and_sewing_sticking_independent_of_p():
    mesh = tube_case()
    sim = make(mesh, None, body_for(mesh))
    x = perturbed(mesh, 0.01, seed=8)
    rng = np.random.default_rng(9)
    lam = rng.standard_normal(x.shape)
    p0 = 0.01 * mesh.uv_cm
    prod = sim.dfdp_T(x, lam)
    dp = rng.standard_normal(p0.shape)
    eps = 1e-7
    sim.set_pattern(p0 + eps * dp); fp = np.sum(lam * sim.force(x))
    sim.set_pattern(p0 - eps * dp); fm = np.sum(lam * sim.force(x))
    sim.set_pattern(p0)
    assert np.sum(prod * dp) == pytest.approx((fp - fm) / (2 * eps), rel=1e-5)
    for term in ("sewing", "sticking"):
        s = make(mesh, term, None)
        assert np.abs(s.dfdp_T(x, lam)).max() == 0.0


def test_stretch_rest_state_honours_shirring_and_is_rigid_invariant():
    mesh = flat_sheet(jitter=0.3)
    sim = make(mesh, "stretch")
    p3 = np.c_[0.01 * mesh.uv_cm, np.zeros(len(mesh.uv_cm))]
    assert sim.energy(p3)[0] == pytest.approx(0.0, abs=1e-20)
    th = 0.7
    R = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    assert sim.energy(p3 @ R.T + 0.3)[0] == pytest.approx(0.0, abs=1e-18)
    # r_s scales the rest length: a garment scaled by r is at rest.
    sim.set_shirring(np.full(sim.n_springs, 0.8))
    assert sim.energy(0.8 * p3)[0] == pytest.approx(0.0, abs=1e-18)
    assert sim.energy(p3)[0] > 1e-6
    # Paper form: E = Y/(2L) (l - r L)^2 for one stretched spring.
    Y = sim.params.stretch_Y
    e = sim.springs[0]
    L = sim.rest_lengths[0]
    x = 0.8 * p3.copy()
    d = x[e[0]] - x[e[1]]
    x[e[0]] += 0.1 * d  # only this spring and its neighbours change
    sim2 = make(mesh, "stretch")
    sim2.set_shirring(np.full(sim.n_springs, 0.8))
    E = sim2.energy(x)[0]
    assert E > 0
    l = np.linalg.norm(x[e[0]] - x[e[1]])
    assert E >= Y / (2 * L) * (l - 0.8 * L) ** 2 * (1 - 1e-12)


def test_bending_zero_on_flat_and_rigid_and_matches_cylinder_energy():
    mesh = equilateral_sheet(0.2, 24)
    kb = 1e-3
    sim = make(mesh, "bending", kb=kb)
    p3 = np.c_[0.01 * mesh.uv_cm, np.zeros(len(mesh.uv_cm))]
    area = 0.2 * 0.2 * np.sqrt(3) / 2
    # Roll the sheet onto a cylinder of radius R along any direction: the plate
    # energy is D/2 * area / R^2 (a few % less here: the boundary strip has no hinges).
    R = 0.08
    for ang in (0.0, 0.4, 0.8):
        c, s = np.cos(ang), np.sin(ang)
        uv = (0.01 * mesh.uv_cm - 0.1) @ np.array([[c, -s], [s, c]]).T
        u, v = uv[:, 0], uv[:, 1]
        xc = np.c_[R * np.sin(u / R), v, R * (1 - np.cos(u / R))]
        E = sim.energy(xc)[0]
        assert E == pytest.approx(kb / 2 * area / R ** 2, rel=0.06)
    # Flat rest state and any affine image of it (incl. rigid motions): no bending
    # (up to round-off of the quadratic form).
    assert sim.energy(p3)[0] <= 1e-10 * E
    A = np.array([[1.1, 0.2, 0.3], [-0.1, 0.9, 0.5], [0.4, 0.1, 1.0]])
    assert sim.energy(p3 @ A.T + 1.0)[0] <= 1e-10 * E
    assert sim.n_hinges > 0


def test_masses_and_gravity():
    mesh = flat_sheet(width_cm=30, height_cm=10, nu=5, nv=3, jitter=0.2)
    sim = make(mesh, "gravity")
    assert sim.masses.sum() == pytest.approx(0.2 * 0.3 * 0.1, rel=1e-12)
    f = sim.force(mesh.x0)
    np.testing.assert_allclose(f.sum(axis=0), sim.masses.sum() * np.array([0.3, -0.2, -9.81]), rtol=1e-12)


def test_sewing_energy_is_quadratic_in_the_gap():
    mesh = tube_case()
    sim = make(mesh, "sewing", Ys=50.0)
    x = mesh.x0
    gaps = sim.sewing_gaps(x)
    assert sim.energy(x)[0] == pytest.approx(0.5 * 50.0 * np.sum(gaps ** 2), rel=1e-12)
    assert sim.n_sewing == len(mesh.sewing_pairs)


def test_barrier_equilibrium_gap_is_mu_times_length():
    # A small flat sheet resting on a floor under its own weight: every vertex
    # balances c_i (1 - phi/d)^2 / phi = m_i g, i.e. mu l_b (1 - phi/d)^2 = phi
    # (phi ~ mu l_b for d >> mu l_b).
    mesh = flat_sheet(width_cm=4, height_cm=4, nu=2, nv=2)
    mesh.x0 = mesh.x0 + np.array([0.0, 0.0, 0.02])
    for mu in (1e-3, 1e-2, 5e-2):
        fabric = Fabric()
        settings = SimSettings(mu=mu, gravity=(0.0, 0.0, -9.81), tolerance=1e-10, sew_first=False,
                               method="newton")
        sim = Simulator(mesh, floor_sdf(z=0.0, size=0.3, spacing=0.05), fabric, settings)
        res = sim.drape()
        assert res.converged, res.message
        a, d = mu * 0.1, settings.barrier_distance
        # root of phi = a (1 - phi/d)^2 in (0, d)
        phi = ((2 * a / d + 1) - np.sqrt((2 * a / d + 1) ** 2 - 4 * a * a / d ** 2)) / (2 * a / d ** 2)
        assert 0 < phi < d and phi == pytest.approx(a * (1 - phi / d) ** 2, rel=1e-12)
        np.testing.assert_allclose(res.x[:, 2], phi, rtol=1e-6)
        assert res.min_phi_mm == pytest.approx(phi * 1000.0, rel=1e-6)
        if mu <= 1e-2:
            assert phi == pytest.approx(a, rel=0.25)


def test_sdf_hessian_outside_grid_is_consistent():
    # Vertices outside the SDF box see the distance-to-box continuation.
    mesh = flat_sheet(width_cm=10, height_cm=10, nu=2, nv=2)
    sdf = sphere_sdf(center=(0, 0, 0), radius=0.05, spacing=0.01, pad=0.03)
    sim = make(mesh, "barrier", sdf)
    x = mesh.x0 + np.array([0.13, 0.11, 0.12])  # beyond the box on every axis
    f = sim.force(x)
    np.testing.assert_allclose(f, fd_force(sim, x), rtol=1e-5, atol=1e-12)
    v = np.random.default_rng(1).standard_normal(x.shape)
    eps = 1e-6
    fd = -(sim.force(x + eps * v) - sim.force(x - eps * v)) / (2 * eps)
    np.testing.assert_allclose(sim.hess_vec(x, v, False), fd, rtol=1e-5, atol=1e-12)


def test_evaluation_inside_body_is_an_error_not_nan():
    mesh = tube_case()
    sim = make(mesh, None, body_for(mesh))
    x = mesh.x0.copy()
    x[0] = [0.0, 0.0, 0.05]  # on the capsule axis
    e, _ = sim.energy(x)
    assert e == np.inf
    with pytest.raises(SolveError, match="inside the body"):
        sim.force(x)
    with pytest.raises(SolveError, match="shape"):
        sim.force(x[:3])
    # The paper's projection: onto the surface, at the barrier's rest gap.
    y, moved = sim.project_outside(x, 1e-9, sim.projection_gap)
    assert moved == 1
    np.testing.assert_array_equal(y[1:], x[1:])
    # (from the capsule's axis, where the field's gradient is weak, Newton steps
    # on phi overshoot a little)
    assert 0.5 * sim.projection_gap <= sim.sample_phi(y, True)[0] <= 5 * sim.projection_gap
    assert np.all(np.isfinite(sim.force(y)))


def test_barrier_vanishes_smoothly_beyond_its_distance():
    mesh = flat_sheet(width_cm=4, height_cm=4, nu=2, nv=2)
    sdf = floor_sdf(z=0.0, size=0.3, spacing=0.05)
    sim = make(mesh, "barrier", sdf, dhat=0.01)
    for z, active in ((0.0101, False), (0.0099, True), (0.002, True)):
        x = mesh.x0 + np.array([0, 0, z])
        e, _ = sim.energy(x)
        f = sim.force(x)
        assert (e > 0) == active and (np.abs(f).max() > 0) == active
        assert np.all(f[:, 2] >= 0)  # it only ever pushes away from the body
    # C1 at the activation distance: the force tends to zero there.
    f_near = sim.force(mesh.x0 + np.array([0, 0, 0.01 - 1e-6]))
    f_in = sim.force(mesh.x0 + np.array([0, 0, 0.005]))
    assert np.abs(f_near).max() < 1e-6 * np.abs(f_in).max()


@pytest.mark.parametrize("smooth", [True, False])
def test_barrier_derivatives_for_both_sdf_readings(smooth):
    # The barrier reads the SDF grid as a C2 cubic B-spline (default) or the
    # trilinear interpolant; force, Hessian and d/dp are exact for both.
    mesh = tube_case()
    sim = make(mesh, "barrier", body_for(mesh), smooth=smooth)
    x = perturbed(mesh, 0.01, seed=11)
    f = sim.force(x)
    np.testing.assert_allclose(f, fd_force(sim, x), atol=2e-6 * np.abs(f).max(), rtol=1e-5)
    v = np.random.default_rng(12).standard_normal(x.shape)
    eps = 1e-6
    fd = -(sim.force(x + eps * v) - sim.force(x - eps * v)) / (2 * eps)
    np.testing.assert_allclose(sim.hess_vec(x, v, False), fd, atol=2e-6 * np.abs(fd).max(), rtol=1e-5)
    lam = np.random.default_rng(13).standard_normal(x.shape)
    p0 = 0.01 * mesh.uv_cm
    dp = np.random.default_rng(14).standard_normal(p0.shape)
    e = 1e-7
    sim.set_pattern(p0 + e * dp); fp = np.sum(lam * sim.force(x))
    sim.set_pattern(p0 - e * dp); fm = np.sum(lam * sim.force(x))
    sim.set_pattern(p0)
    assert np.sum(sim.dfdp_T(x, lam) * dp) == pytest.approx((fp - fm) / (2 * e), rel=1e-5)


def test_smooth_barrier_field_is_close_to_the_grid_and_c1():
    mesh = tube_case()
    sdf = body_for(mesh)
    sim = make(mesh, "barrier", sdf, smooth=True)
    rng = np.random.default_rng(3)
    # points near the capsule surface (radius 0.1)
    ang = rng.uniform(0, 2 * np.pi, 300)
    r = 0.1 + rng.uniform(-0.02, 0.03, 300)
    pts = np.c_[r * np.cos(ang), r * np.sin(ang), rng.uniform(0.0, 0.2, 300)]
    pts = pts[: sim.n_vertices] if len(pts) > sim.n_vertices else np.vstack([pts, np.tile(pts[:1], (sim.n_vertices - len(pts), 1))])
    smooth = sim.sample_phi(pts, True)
    grid = sim.sample_phi(pts, False)
    exact = np.hypot(pts[:, 0], pts[:, 1]) - 0.1
    # B-spline smoothing of a 1 cm grid on a 10 cm radius: h^2/6 * (1/R) ~ 0.17 mm
    assert np.abs(smooth - exact).max() < 0.5e-3
    assert np.abs(grid - exact).max() < 0.5e-3
    # C1 across a cell face: the gradient does not jump (trilinear does).
    h = sdf.spacing
    face = sdf.origin[0] + h * np.round((0.1 - sdf.origin[0]) / h)
    a = np.tile([face - 1e-7, 0.003, 0.1031], (sim.n_vertices, 1))
    b = np.tile([face + 1e-7, 0.003, 0.1031], (sim.n_vertices, 1))
    pr = sim.params
    for smooth_flag, jumps in ((True, False), (False, True)):
        pr.barrier_smooth = smooth_flag
        sim.params = pr
        ga, gb = sim.force(a)[0], sim.force(b)[0]
        jump = np.abs(ga - gb).max() / np.abs(ga).max()
        assert (jump > 1e-3) == jumps, jump


def test_sdf_is_used_in_place_and_kept_alive():
    # A body's field is large: the core reads the caller's float32 grid in
    # place (no copy) and keeps it alive as long as it needs it.
    import gc
    mesh = tube_case()
    sdf = body_for(mesh)
    values = np.array(sdf.values, dtype=np.float32, order="C")
    sim = make(mesh, "barrier", None)
    sim.set_sdf(values, sdf.origin, sdf.spacing)
    x = perturbed(mesh, 0.01, seed=21)
    phi0 = sim.sample_phi(x, False).copy()
    values += np.float32(0.001)  # visible through the simulator: same memory
    np.testing.assert_allclose(sim.sample_phi(x, False), phi0 + 0.001, atol=1e-6)
    values -= np.float32(0.001)
    del values
    gc.collect()
    np.testing.assert_allclose(sim.sample_phi(x, False), phi0, atol=1e-6)
    with pytest.raises(TypeError):  # not float32: converted by the Python layer, refused by the core
        sim.set_sdf(sdf.values.astype(np.float64), sdf.origin, sdf.spacing)
