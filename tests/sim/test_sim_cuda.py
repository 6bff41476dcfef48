"""The simulator on every available device against the CPU simulator.

Each test runs once per device in DEVICES: "cpu" always, "cuda" where a GPU is
present (seamfit._core.cuda_device_count() > 0). On the GPU the force and the
energy terms equal the CPU's to 1e-12 relative (float64, same term functions,
differing only in summation order and fused multiply-adds); a GPU solve stops
with the CPU's verdicts, its residual re-evaluated on the CPU meets the
tolerance, and its drape lies within 0.01 mm of the CPU's where the
equilibrium is unique (where it is not, the energies agree to 1e-4).

Real-garment meshes need gmsh; on machines without it, SEAMFIT_TEST_MESH_CACHE
names a folder of meshes built elsewhere (written there when gmsh is present).
"""
from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from seamfit._native import core
from seamfit.errors import DeviceError, SolveError
from seamfit.sim import Fabric, SimSettings, Simulator

from sim_helpers import capsule_sdf, flat_sheet, hourglass_sdf, sewn_tube, sphere_sdf
from common import DEVICES, SAMPLES

TERMS = ("stretch", "sewing", "bending", "gravity", "sticking", "barrier")
REL = 1e-12  # float64 agreement of forces and energies, relative to their scale (see below)


def evaluator(sim, device, **options):
    """The object whose force / energy run on `device`."""
    if device == "cpu":
        return sim
    from seamfit.sim.cuda import CudaSimulator
    return CudaSimulator(sim, **options)


def barrier_rounding(sim, x):
    """Per vertex, what a rounding difference in phi does to the barrier
    force: its stiffness c / phi^2 times the rounding bound of phi's 64-term
    B-spline sum, 64 * 2^-53 * (|phi| + 4 h). It matters only for vertices
    pressed to within nanometres of the body, where the solver may leave them
    (the projection floor is 1e-9 m)."""
    pr = sim.core.params
    if not sim.core.has_sdf or pr.mu <= 0:
        return np.zeros(len(x))
    phi = sim.phi(x, barrier_field=True)
    m = np.maximum(sim.masses, 1e-3 * sim.masses.mean())
    c = pr.mu * pr.barrier_length * 9.81 * m
    dphi = 64 * 2.0**-53 * (np.abs(phi) + 4 * float(sim.sdf.spacing))
    return np.where(phi < pr.barrier_distance, c / phi**2 * dphi, 0.0)


def assert_same_force_and_energy(sim, ev, x, rel=REL):
    """Force to `rel` of the larger of its largest component and the spring
    force scale Y (N): near equilibrium the net force is far smaller than the
    spring forces it balances, and their rounding (the cancellation in
    l - r L) scales with Y, not with the net force; plus, per vertex, the
    barrier's amplification of rounding in phi. Energy terms to `rel` of the
    sum of their magnitudes."""
    f_cpu = sim.force(x)
    f_dev = ev.force(x)
    scale = max(np.abs(f_cpu).max(), sim.core.params.stretch_Y)
    assert scale > 0
    excess = np.abs(f_dev - f_cpu) - barrier_rounding(sim, x)[:, None]
    err = max(excess.max(), 0.0) / scale
    assert err <= rel, f"force differs by {err:.3g} of its scale {scale:.3g} N"
    e_cpu, t_cpu = sim.energy(x)
    e_dev, t_dev = ev.energy(x)
    escale = sum(abs(v) for v in t_cpu.values())
    for t in TERMS:
        assert abs(t_dev[t] - t_cpu[t]) <= rel * escale, (t, t_dev[t], t_cpu[t])
    assert abs(e_dev - e_cpu) <= rel * escale
    return err


def tube_sim(smooth=True, sticking=True, **settings):
    mesh = sewn_tube(radius_m=0.1, height_cm=12.0, nu=6, nv=4, gap_m=0.03, jitter=0.2)
    body = capsule_sdf(radius=0.1, z_lo=-0.1, z_hi=0.3, spacing=0.01)
    st = SimSettings(barrier_distance=0.06, barrier_interpolation="cubic" if smooth else "trilinear",
                     gravity=(0.3, -0.2, -9.81), **settings)
    sim = Simulator(mesh, body, Fabric(), st)
    if sticking:
        rng = np.random.default_rng(5)
        pins = np.flatnonzero(rng.random(sim.n_vertices) < 0.3)
        sim.set_sticking(pins, mesh.x0[pins] + 0.02 * rng.standard_normal((len(pins), 3)), stiffness=40.0)
    return mesh, sim


def perturbed(x, scale, seed):
    return x + scale * np.random.default_rng(seed).standard_normal(x.shape)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("smooth", [True, False])
def test_force_and_energy_match_cpu_on_sewn_tube(device, smooth):
    mesh, sim = tube_sim(smooth=smooth)
    ev = evaluator(sim, device)
    for seed in range(3):
        x = perturbed(mesh.x0, 0.01, seed)
        assert np.all(sim.phi(x, barrier_field=True) > 0)
        _, terms = sim.energy(x)
        assert all(terms[t] != 0 for t in TERMS)  # every term is active at the test states
        assert_same_force_and_energy(sim, ev, x)


def assert_same_hess_vec(sim, ev, x, seed, rel=REL):
    """(d2E/dx2) v on the device against the CPU's assembled Hessian times v, exact and
    PSD-projected, to `rel` of the rounding scale |H| |v| (row sums of magnitudes); plus,
    per vertex, the barrier's amplification of rounding in phi, as for the force: its
    stiffness c / phi^2 moves by 2 c / phi^3 per unit of phi, so by 2 / phi times the
    force's allowance (barrier_rounding) per unit of |v|. (On an H100 the pencil skirt
    pressed onto the body differed by 3.0e-12 of the scale without it.)"""
    v = np.random.default_rng(seed).standard_normal(x.shape)
    phi = np.maximum(sim.phi(x, barrier_field=True), 1e-300)
    allow = 2.0 / phi * barrier_rounding(sim, x) * np.abs(v).max(axis=1)
    for psd in (False, True):
        H = sim.hessian(x, psd=psd).tocsr()
        ref = (H @ v.reshape(-1)).reshape(-1, 3)
        scale = float((abs(H) @ np.abs(v.reshape(-1))).max())
        got = ev.hess_vec(x, v, psd=psd)
        err = max(float((np.abs(got - ref) - allow[:, None]).max()), 0.0) / scale
        assert err <= rel, f"psd={psd}: Hessian product differs by {err:.3g} of its scale {scale:.3g}"


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("smooth", [True, False])
def test_hessian_product_matches_the_assembled_hessian(device, smooth, skirt):
    """The matrix-free product the adjoint's iterative solve needs: on the CPU against
    its own assembled Hessian, on the GPU against the same; every term active (sewn
    tube), and the skirt pressed onto the body (barrier Hessian with the field's
    curvature)."""
    mesh, sim = tube_sim(smooth=smooth)
    ev = evaluator(sim, device)
    for seed in range(2):
        assert_same_hess_vec(sim, ev, perturbed(mesh.x0, 0.01, seed), seed)
    skirt_mesh, sdf = skirt
    sim = Simulator(skirt_mesh, sdf, Fabric(), SimSettings(
        barrier_distance=0.03, barrier_interpolation="cubic" if smooth else "trilinear"))
    x = sim.solve(skirt_mesh.x0, max_iterations=400, gravity_scale=0.0).x
    assert np.min(sim.phi(x, barrier_field=True)) < 0.03
    assert_same_hess_vec(sim, evaluator(sim, device), x, 7)


def sample_skirt():
    """GarmentCode pencil skirt (size 06) at 3 cm edges with its start positions."""
    cache = os.environ.get("SEAMFIT_TEST_MESH_CACHE")
    path = Path(cache) / "gc_pencil_skirt_size06_3cm.npz" if cache else None
    if path is not None and path.exists():
        d = np.load(path)
        return SimpleNamespace(**{k: d[k] for k in d.files})
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    from seamfit.sim.dressing import initial_positions
    pattern = load_pattern(SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json")
    mesh = build_sewn_mesh(pattern, 3.0)
    x0, _ = initial_positions(mesh, pattern, None, mode="none")
    out = SimpleNamespace(uv_cm=np.asarray(mesh.uv_cm), triangles=np.asarray(mesh.triangles),
                          sewing_pairs=np.asarray(mesh.sewing_pairs), x0=np.asarray(x0))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **vars(out))
    return out


@pytest.fixture(scope="module")
def skirt():
    from seamfit.body import build_sdf, load_body
    body = load_body(SAMPLES / "bodies" / "women_size06.obj")
    return sample_skirt(), build_sdf(body, spacing=0.01)


def test_force_and_energy_match_cpu_on_sample_skirt(device, skirt):
    mesh, sdf = skirt
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(barrier_distance=0.03))
    ev = evaluator(sim, device)
    # The start placement, and a state where the seams have pulled the panels
    # around the body (barrier active).
    assert_same_force_and_energy(sim, ev, mesh.x0)
    x = sim.solve(mesh.x0, max_iterations=400, gravity_scale=0.0).x
    assert np.min(sim.phi(x, barrier_field=True)) < 0.03
    _, terms = sim.energy(x)
    assert terms["barrier"] > 0
    assert_same_force_and_energy(sim, ev, x)


# float32 storage and the GPU's df/dp exist on the GPU alone
@pytest.mark.gpu
@pytest.mark.parametrize("device", ["cuda"])
def test_float32_rest_state_stays_within_its_rounding(device, skirt):
    """float32 storage of the rest state (rest lengths, shirring, bending
    matrix, masses, barrier weights): the force moves by what rounding a rest
    length to 2^-24 does to a spring force (about Y 2^-24 per spring), far
    more than float64's 1e-12; docs/gpu_backend.md weighs it against the residual."""
    mesh, sdf = skirt
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(barrier_distance=0.03))
    x = sim.solve(mesh.x0, max_iterations=400, gravity_scale=0.0).x
    f64 = evaluator(sim, device).force(x)
    f32 = evaluator(sim, device, float_rest=True).force(x)
    Y = sim.core.params.stretch_Y
    degree = np.bincount(sim.springs.ravel()).max()
    err = np.abs(f32 - f64).max()
    assert 0 < err <= 2.0 * degree * Y * 2.0**-24


@pytest.mark.gpu
@pytest.mark.parametrize("device", ["cuda"])
@pytest.mark.parametrize("float_rest", [False, True])
def test_dfdp_product_matches_cpu(device, float_rest, skirt):
    """(df/dp)^T lam on the GPU against the CPU's, with all its terms: springs, hinges,
    gravity and the barrier (vertices near the body) through the masses; after a new
    pattern and shirring, which it reads from the CPU simulator at each call. The
    rest state is read in float64 even where the solver stores it in float32."""
    mesh, sdf = skirt
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(barrier_distance=0.03))
    x = sim.solve(mesh.x0, max_iterations=400).x
    assert np.min(sim.phi(x)) < 0.03  # the barrier is active somewhere
    ev = evaluator(sim, device, float_rest=float_rest)
    lam = np.random.default_rng(5).standard_normal(x.shape)
    for step in range(2):
        ref = sim.dfdp_T(x, lam)
        got = ev.dfdp_T(x, lam)
        scale = np.abs(ref).max()
        assert scale > 0 and np.abs(got - ref).max() <= 1e-12 * scale
        sim.set_pattern(1.02 * sim.p)
        sim.set_shirring(np.linspace(0.95, 1.05, sim.core.n_springs))


def sheet_on_ball(device, tol, **gpu_options):
    """A sheet hanging from two pinned corners, pressed out by a ball behind
    it: one equilibrium, with contact (the ball pushes 15 vertices out)."""
    mesh = flat_sheet(width_cm=20, height_cm=20, nu=10, nv=10, jitter=0.2)
    mesh.x0 = np.c_[mesh.x0[:, 0], np.zeros(len(mesh.x0)), mesh.x0[:, 1]]
    body = sphere_sdf(center=(0.1, 0.09, 0.08), radius=0.1, spacing=0.01)
    sim = Simulator(mesh, body, Fabric(), SimSettings(sew_first=False, tolerance=tol, max_iterations=400000,
                                                      device=device))
    top = np.flatnonzero(mesh.uv_cm[:, 1] > 19.99)
    corners = top[[np.argmin(mesh.uv_cm[top, 0]), np.argmax(mesh.uv_cm[top, 0])]]
    sim.set_sticking(corners, mesh.x0[corners], stiffness=200.0)
    if gpu_options:
        from seamfit.sim.cuda import CudaSimulator
        sim._gpu = CudaSimulator(sim, **gpu_options)
    return sim


def test_drape_with_contact_matches_cpu(device):
    """Same equilibrium as the CPU's to 0.01 mm (two CPU runs from starts 1 nm
    apart agree to 0.0003 mm), reached with the same verdict."""
    tol = 1e-5
    ref = sheet_on_ball("cpu", tol).drape()
    sim = sheet_on_ball(device, tol)
    res = sim.drape()
    assert ref.converged and res.converged, (ref.message, res.message)
    assert ref.energy_terms["barrier"] > 0 and res.stages[0]["projections"] == ref.stages[0]["projections"] > 0
    assert res.residual <= tol
    assert sim.residual(res.x) == pytest.approx(res.residual, rel=1e-9)  # the CPU's residual at the device's x
    assert np.abs(res.x - ref.x).max() <= 1e-5


def test_tube_drape_matches_cpu(device):
    """Sew and settle a tube on a torso on the device and on the CPU. The
    settle has nearby equilibria of almost equal energy (on the CPU alone, starts
    1 nm apart end 33 mm apart at one fold, their energies up to 8.6e-5 of it
    apart), so the drapes are compared by verdicts, residual, seams, contact and
    energy (to 5e-4 of it; the device's was 2.4e-4 from the CPU's)."""
    mesh = sewn_tube(radius_m=0.12, height_cm=30, nu=10, nv=6, gap_m=0.05, z0=0.2, ease=1.1)
    body = hourglass_sdf(spacing=0.01)
    tol = 1e-4

    def drape(dev):
        sim = Simulator(mesh, body, Fabric(), SimSettings(tolerance=tol, max_iterations=200000, device=dev))
        return sim, sim.drape()

    cpu_sim, ref = drape("cpu")
    sim, res = drape(device)
    assert ref.converged and res.converged, (ref.message, res.message)
    # Both sew, then settle; a settle that stagnates short of the tolerance is finished
    # by the Newton polish, and rounding (the order of sums) decides on which side that
    # happens, so the polish may appear on one side only. The verdict is the same: converged.
    assert [s["stage"] for s in res.stages][:2] == ["sew", "settle"] == [s["stage"] for s in ref.stages][:2]
    assert res.stages[-1]["converged"] and ref.stages[-1]["converged"]
    assert res.residual <= tol
    assert cpu_sim.residual(res.x) == pytest.approx(res.residual, rel=1e-9)
    assert res.max_sewing_gap_mm <= 2.0 and res.min_phi_mm >= -1.0
    e_ref, e_dev = sum(ref.energy_terms.values()), sum(res.energy_terms.values())
    assert abs(e_dev - e_ref) <= 5e-4 * abs(e_ref)


def test_solve_report_budgets_and_cancel(device):
    mesh = sewn_tube(radius_m=0.12, height_cm=30, nu=10, nv=6, gap_m=0.05, z0=0.2)
    body = hourglass_sdf(spacing=0.01)
    # Both devices follow the same control rules; without the two economies (lagged spring
    # blocks, bounded far steps) no decision hangs on the order of sums, so both take the
    # very same iteration.
    same = dict(precond_refresh=1, far_bound=False)
    sim = Simulator(mesh, body, Fabric(), SimSettings(tolerance=1e-12, sew_first=False, device=device,
                                                      history_every=10, progress_every=10, **same))
    ref = Simulator(mesh, body, Fabric(), SimSettings(tolerance=1e-12, sew_first=False, history_every=10, **same))
    # Iteration budget: stops exactly there, same report keys as the CPU's.
    a = sim.solve(max_iterations=50)
    b = ref.solve(max_iterations=50)
    assert set(b.stages[0]) <= set(a.stages[0])
    assert a.iterations == 50 and not a.converged and not a.cancelled
    assert "iteration budget" in a.message
    assert a.stages[0]["history_iteration"] == list(range(0, 51, 10))
    assert np.all(np.isfinite(a.stages[0]["history_residual"]))
    assert sim.residual(a.x) == pytest.approx(a.residual, rel=1e-9)
    # After 50 identical iterations the states agree closely.
    assert np.abs(a.x - b.x).max() <= 1e-6
    # Time budget.
    t = Simulator(mesh, body, Fabric(), SimSettings(tolerance=1e-12, max_seconds=0.05, max_iterations=10**9,
                                                    sew_first=False, device=device)).solve()
    assert not t.converged and "time budget" in t.message
    # A progress callback that asks to stop cancels; one that raises re-raises.
    seen = []

    def cb(it, res):
        seen.append((it, res))
        return it < 100

    c = sim.solve(max_iterations=5000, progress=cb)
    assert c.cancelled and not c.converged and "cancelled" in c.message
    assert seen[0][0] == 0 and seen[-1][0] >= 100 and c.iterations >= 100
    assert np.all(np.isfinite(c.x)) and all(np.isfinite(r) for _, r in seen)

    def bad(it, res):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        sim.solve(max_iterations=5000, progress=bad)


def test_changes_to_the_model_reach_the_device(device):
    """Parameters, pattern, shirring and sticking changed on the simulator are
    what the device evaluates after a sync (solve syncs by itself)."""
    mesh, sim = tube_sim(sticking=False)
    ev = evaluator(sim, device)
    x = perturbed(mesh.x0, 0.01, 7)
    sim._apply_params(gravity_scale=0.5, sewing_scale=2.0)
    sim.set_pattern(1.05 * sim.p)
    sim.set_shirring(np.linspace(0.9, 1.1, sim.core.n_springs))
    sim.set_sticking([0, 3, 5], mesh.x0[[0, 3, 5]], stiffness=60.0)
    if device != "cpu":
        ev.sync()
    assert_same_force_and_energy(sim, ev, x)


def test_rest_state_follows_a_new_pattern(device):
    """A new pattern's rest state, computed when first needed on the CPU and by the
    device itself on the GPU: scaling the pattern by s scales rest lengths by s and
    masses (pattern areas) by s^2, and the device's equals the CPU's."""
    mesh, sim = tube_sim(sticking=False)
    p0 = np.array(sim.p)
    L0, m0, w0 = sim.core.rest_lengths.copy(), sim.masses.copy(), sim.core.weight_norm
    ev = evaluator(sim, device)
    for s in (1.05, 0.9):
        sim.set_pattern(s * p0)
        if device == "cpu":
            L, m, w = sim.core.rest_lengths, sim.masses, sim.core.weight_norm
        else:
            r = ev.rest_state()
            L, m, w = r["rest_lengths"], r["masses"], r["weight_norm"]
            np.testing.assert_allclose(L, sim.core.rest_lengths, rtol=1e-15, atol=0)
            np.testing.assert_allclose(m, sim.masses, rtol=1e-14, atol=0)
            assert w == pytest.approx(sim.core.weight_norm, rel=1e-14)
        np.testing.assert_allclose(L, s * L0, rtol=1e-14)
        np.testing.assert_allclose(m, s * s * m0, rtol=1e-13)
        assert w == pytest.approx(s * s * w0, rel=1e-13)
    # A new density after a new pattern: the masses follow both.
    sim.set_pattern(1.1 * p0)
    pr = sim.core.params
    pr.density *= 2.0
    sim.core.params = pr
    m = sim.masses if device == "cpu" else ev.rest_state()["masses"]
    np.testing.assert_allclose(m, 2.0 * 1.21 * m0, rtol=1e-13)
    if device != "cpu":
        np.testing.assert_allclose(m, sim.masses, rtol=1e-14)


def test_cuda_request_without_a_gpu_fails_clearly(monkeypatch):
    """--device cuda on a machine without a GPU names the reason."""
    mesh, sim = tube_sim(sticking=False)
    monkeypatch.setattr(core(), "cuda_device_count", lambda: 0)
    from seamfit.sim.cuda import CudaSimulator
    with pytest.raises(DeviceError, match="cuda: (no CUDA GPU|this seamfit build has no CUDA)"):
        CudaSimulator(sim)
    with pytest.raises(DeviceError, match="cuda"):
        sim.solve(mesh.x0, max_iterations=10, device="cuda")
    with pytest.raises(DeviceError, match="unknown device"):
        sim.solve(mesh.x0, max_iterations=10, device="tpu")


def test_device_settings_are_validated():
    mesh, _ = tube_sim(sticking=False)
    with pytest.raises(SolveError, match="unknown device"):
        Simulator(mesh, None, settings=SimSettings(device="tpu"))
    with pytest.raises(SolveError, match="unknown method .gauss-seidel.; choose one of chebyshev, newton"):
        Simulator(mesh, None, settings=SimSettings(device="cuda", method="gauss-seidel"))
