"""The search's state on the GPU (seamfit.device_arrays): DeviceArrays that round-trip
losslessly, every piece of an outer iteration answering a DeviceArray as it answers a NumPy
array, a pattern set on the GPU alone reaching the CPU model when a CPU method needs it,
starts that need the CPU's projection taking the host path, and the grading loop on GPU
state ending where the loop on host arrays ends.

Everything here needs a GPU: the cases exist where one is present (not collected elsewhere,
rather than reported as skipped). What runs everywhere: a build or machine without CUDA
never sees a DeviceArray (``is_device`` is False for every NumPy array).
"""
from __future__ import annotations


import contextlib

import numpy as np
import pytest

from seamfit._native import core
from seamfit.device_arrays import host, is_device
from benchmarks.measure_switches import host_state
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0, B1 = SAMPLES / "bodies/women_size06.obj", SAMPLES / "bodies/women_size10.obj"


def test_numpy_arrays_are_never_device_arrays():
    assert not is_device(np.zeros((3, 2)))
    a = np.arange(6.0).reshape(3, 2)
    assert host(a) is a


@pytest.mark.gpu
def test_device_arrays_round_trip_losslessly_and_do_their_arithmetic():
    D = core().DeviceArray
    rng = np.random.default_rng(0)
    a = rng.normal(size=(1001, 3)) * np.exp(rng.uniform(-300, 300, size=(1001, 3)))
    a[0, 0], a[1, 1] = 5e-324, -0.0   # a subnormal and a signed zero survive too
    d = D(a)
    assert d.shape == (1001, 3)
    back = d.numpy()
    assert back.tobytes() == a.tobytes()
    b = rng.normal(size=a.shape)
    y = D(b)
    y.axpy(-0.37, D(a / 1e300))
    want = b + (-0.37) * (a / 1e300)
    assert y.numpy().tobytes() == want.tobytes()   # rounded as NumPy rounds it (no fused multiply-add)
    assert d.max_abs() == np.max(np.abs(a))
    c = a.copy()
    c[500, 2] = np.nan
    assert np.isnan(D(c).max_abs())
    z = D.zeros(4, 2)
    assert z.numpy().tobytes() == np.zeros((4, 2)).tobytes() and D.zeros(0, 3).max_abs() == 0.0
    z.upload(np.ones((4, 2)))
    d2 = D.zeros(4, 2)
    d2.copy_from(z)
    assert np.array_equal(d2.numpy(), np.ones((4, 2)))
    with pytest.raises(ValueError, match=r"an array of shape \(2, 4\) into a DeviceArray of shape \(4, 2\)"):
        z.upload(np.ones((2, 4)))
    with pytest.raises(Exception, match="copy of 8 entries into 6"):
        D.zeros(3, 2).copy_from(z)


@pytest.fixture(scope="module")
def ctx():
    """A grading context on the GPU (4 cm mesh) with R^seam on, and the exact target drape."""
    from dataclasses import replace

    from grading_helpers import settled_sample_grading
    from seamfit.opt.presets import preset

    c, x = settled_sample_grading(4.0, "cuda", strengths=replace(preset("dress").strengths, seam=10.0))
    c.extra["x"] = x
    return c


def _close(a, b, rel=1e-12):
    a, b = host(a), host(b)
    assert a.shape == b.shape
    scale = max(float(np.abs(b).max()), 1e-300)
    assert float(np.abs(a - b).max()) <= rel * scale, (float(np.abs(a - b).max()), scale)


@pytest.mark.gpu
def test_every_piece_answers_device_arrays_as_numpy_arrays(ctx):
    """p(theta) and its adjoint, the costs, R, R^seam, P^-1 and the simulator's steps: the
    same kernels behind both entry points, so the same numbers (to rounding)."""
    from seamfit.device_arrays import to_device

    D = core().DeviceArray
    assert ctx.param.device == ctx.regs.device == ctx.seam.device == ctx.costs.device == "cuda"
    assert ctx.seam.active
    rng = np.random.default_rng(1)
    theta = ctx.param.theta_bar * 1.01 + rng.normal(0, 1e-3, ctx.param.theta_bar.shape)
    td = D(theta)
    p = ctx.param.pattern(theta)
    pd = ctx.param.pattern(td)
    assert is_device(pd)
    _close(pd, p)
    g2 = rng.normal(size=p.shape)
    _close(ctx.param.adjoint(D(g2)), ctx.param.adjoint(g2))
    x = ctx.extra["x"]
    c, terms, gx, gp = ctx.costs.evaluate(x, p)
    cd, terms_d, gxd, gpd = ctx.costs.evaluate(to_device(x), pd)
    assert cd == pytest.approx(c, rel=1e-12) and terms_d == pytest.approx(terms, rel=1e-12)
    _close(gxd, gx)
    _close(gpd, gp)
    r, rt, gr = ctx.regs.evaluate(theta)
    rd, rtd, grd = ctx.regs.evaluate(td)
    assert rd == pytest.approx(r, rel=1e-12) and rtd == pytest.approx(rt, rel=1e-12)
    _close(grd, gr)
    gt = rng.normal(size=theta.shape)
    _close(ctx.regs.apply_preconditioner(D(gt)), ctx.regs.apply_preconditioner(gt))
    v, gs = ctx.seam.evaluate(theta)
    vd, gsd = ctx.seam.evaluate(td)
    assert vd == pytest.approx(v, rel=1e-12)
    _close(gsd, gs)
    # The inexact step: the same Chebyshev iterations from the same start.
    ctx.sim.set_pattern(p)
    xh, rep = ctx.sim.iterate(x, 64)
    xd = to_device(x)
    ctx.sim.set_pattern(pd)
    xd2, rep_d = ctx.sim.iterate(xd, 64)
    assert xd2 is xd
    assert rep_d["iterations"] == rep["iterations"] == 64
    assert rep_d["residual"] == pytest.approx(rep["residual"], rel=1e-9)
    _close(xd, xh, rel=1e-12)


@pytest.mark.gpu
def test_the_adjoint_gradient_on_device_arrays_matches_the_host_one(ctx):
    """The whole gradient of f (costs, MINRES, (df/dp)^T lam, the adjoint of p(theta), R and
    R^seam), from the settled state and from an inexact one, on both kinds of array."""
    from seamfit.opt.adjoint import AdjointSolver
    from seamfit.device_arrays import to_device
    from seamfit.opt.objective import Objective

    x = ctx.extra["x"]
    theta = ctx.param.theta_bar * 1.005
    ctx.sim.set_pattern(ctx.param.pattern(theta))
    x_inexact, rep = ctx.sim.iterate(x, 32)
    for xs, res in ((x, None), (x_inexact, float(rep["residual"]))):
        grads = []
        for wrap in (np.asarray, to_device):
            adj = AdjointSolver(ctx.sim, device="cuda", equilibrium_tolerance=ctx.adjoint.equilibrium_tolerance,
                                inexact_forcing=0.01)
            obj = Objective(ctx.param, ctx.regs, ctx.costs, ctx.sim, adj, ctx.seam)
            ctx.sim.set_pattern(ctx.param.pattern(theta))
            f, g = obj.gradient(wrap(xs), wrap(theta), residual=res)
            grads.append((f, host(g).copy(), adj.minres_iterations, adj.gpu_fallbacks))
        (f_h, g_h, it_h, fb_h), (f_d, g_d, it_d, fb_d) = grads
        assert f_d == pytest.approx(f_h, rel=1e-12)
        assert it_d == it_h and fb_d == fb_h == 0
        _close(g_d, g_h, rel=1e-9)


@pytest.mark.gpu
def test_a_fallback_to_the_cpu_factorization_sees_the_pattern_set_on_the_gpu(ctx):
    """A MINRES solve that cannot converge at a settled state falls back to the CPU's direct
    solve. With the state on the GPU the CPU model is behind (the pattern was set there
    alone): the fallback brings it up first, so its gradient is the host path's."""
    from seamfit.opt.adjoint import AdjointSolver
    from seamfit.device_arrays import to_device
    from seamfit.opt.objective import Objective

    x = ctx.extra["x"]
    theta = ctx.param.theta_bar * 1.004
    ctx.sim.set_pattern(ctx.param.pattern(ctx.param.theta_bar))   # the CPU model: another pattern
    grads = []
    for wrap in (np.asarray, to_device):
        adj = AdjointSolver(ctx.sim, device="cuda", equilibrium_tolerance=1e3, gpu_max_iterations=3)
        obj = Objective(ctx.param, ctx.regs, ctx.costs, ctx.sim, adj, ctx.seam)
        th = wrap(theta)
        ctx.sim.set_pattern(ctx.param.pattern(th))
        if wrap is to_device:
            assert ctx.sim.cuda().device_pattern_ahead
        f, g = obj.gradient(wrap(x), th, residual=1e-4)
        assert adj.gpu_fallbacks == 1 and adj.extended == 1
        grads.append((f, host(g).copy()))
    assert not ctx.sim.cuda().device_pattern_ahead
    assert grads[1][0] == pytest.approx(grads[0][0], rel=1e-12)
    _close(grads[1][1], grads[0][1], rel=1e-9)


@pytest.mark.gpu
def test_pieces_left_on_the_cpu_take_gpu_state_too(monkeypatch):
    """A parametrization and a P^-1 too large for GPU memory stay on the CPU; with the
    search's state on the GPU they copy in and out, and the search is the host loop's."""
    from dataclasses import replace

    from seamfit.body import load_body
    from seamfit.opt import Parametrization, Regularizers
    from seamfit.opt.grade import GradeSettings, grade
    from seamfit.opt.presets import preset
    from seamfit.pattern import load_pattern

    monkeypatch.setattr(Parametrization, "GPU_MAX_BYTES", 1024)
    monkeypatch.setattr(Regularizers, "GPU_MAX_BYTES", 1024)
    runs = {}
    for on in (True, False):
        s = GradeSettings(strengths=replace(preset("dress").strengths, smo=0.0), edge_length_cm=4.0,
                          sdf_spacing=0.005, max_outer_iterations=24, checkpoint_every=8, device="cuda",
                          evaluate_base_pattern=False)
        with contextlib.nullcontext() if on else host_state():
            runs[on] = grade(load_pattern(PATTERN), load_body(B0), load_body(B1), s)
    dev, hst = runs[True].report, runs[False].report
    assert dev["devices"]["parametrization"] == dev["devices"]["regularizers"] == "cpu"
    assert dev["state_on_gpu"] is True
    assert dev["objective_final"] == hst["objective_final"]
    assert np.array_equal(np.asarray(runs[True].uv_cm), np.asarray(runs[False].uv_cm))


@pytest.mark.gpu
def test_a_pattern_set_on_the_gpu_alone_reaches_the_cpu_model(ctx):
    """set_pattern(DeviceArray) leaves the CPU model behind until a CPU method needs it; then
    it comes down, and the CPU's energy is the GPU's again. A later host set_pattern wins."""
    D = core().DeviceArray
    x = ctx.extra["x"]
    sim = ctx.sim
    p_new = ctx.param.pattern(ctx.param.theta_bar * 1.02)
    sim.set_pattern(ctx.param.pattern(ctx.param.theta_bar))
    sim.set_pattern(D(p_new))
    assert sim.cuda().device_pattern_ahead
    e_gpu = sim.cuda().energy(x)[0]
    e_cpu = sim.energy(x)[0]   # brings the CPU model up first
    assert not sim.cuda().device_pattern_ahead
    assert np.array_equal(sim.p, p_new)
    assert e_cpu == pytest.approx(e_gpu, rel=1e-10)
    sim.set_pattern(D(p_new * 1.01))
    sim.set_pattern(p_new)            # the host's pattern replaces the device's at the next sync
    assert not sim.cuda().device_pattern_ahead
    sim.cuda().sync()
    assert sim.cuda().energy(x)[0] == pytest.approx(e_gpu, rel=1e-10)


@pytest.mark.gpu
def test_a_start_the_cpu_would_project_takes_the_host_path(ctx):
    """A vertex pushed into the body: the device solve hands the start to the host path,
    which projects it as the CPU solver does, so both end at the same state; a state that is
    not finite is refused with the vertex named, as on the host."""
    from seamfit.errors import SolveError
    from seamfit.device_arrays import to_device

    sim = ctx.sim
    sim.set_pattern(ctx.param.pattern(ctx.param.theta_bar))
    x = ctx.extra["x"].copy()
    v = int(np.argmin(sim.phi(x)))
    x[v] -= 0.02 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2)   # 2 cm sideways: inside on a hip
    if sim.phi(x)[v] >= 0:
        x[v] = [0.0, 0.0, float(x[v, 2])]                     # the body's axis, certainly inside
    assert sim.phi(x)[v] < 0
    xh, rep = sim.iterate(x, 16)
    xd, rep_d = sim.iterate(to_device(x), 16)
    assert rep_d["projections"] == rep["projections"] >= 1
    _close(xd, xh, rel=1e-12)
    bad = ctx.extra["x"].copy()
    bad[7, 1] = np.nan
    with pytest.raises((SolveError, Exception), match="vertex 7 is not finite"):
        sim.iterate(to_device(bad), 4)


@pytest.mark.gpu
def test_the_search_on_gpu_state_ends_where_the_host_loop_ends(ctx):
    """The same grading with theta and x in GPU memory between checkpoints and with the loop on
    host arrays: the same kernels in the same order, so the same search, bit for bit (objective
    pattern to 0.01 mm), and the report says which ran."""
    from dataclasses import replace

    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings, grade
    from seamfit.opt.presets import preset
    from seamfit.pattern import load_pattern

    runs = {}
    for on in (True, False, False):
        s = GradeSettings(strengths=replace(preset("dress").strengths, smo=0.0), edge_length_cm=4.0,
                          sdf_spacing=0.005, max_outer_iterations=48, checkpoint_every=16, device="cuda",
                          evaluate_base_pattern=False)
        with contextlib.nullcontext() if on else host_state():
            runs.setdefault(on, []).append(grade(load_pattern(PATTERN), load_body(B0), load_body(B1), s))
    # The host loop twice first: the GPU's search is deterministic run to run.
    h1, h2 = runs[False]
    print("host loop twice:", h1.report["objective_final"], h2.report["objective_final"],
          "gpu state:", runs[True][0].report["objective_final"])
    assert h1.report["objective_final"] == h2.report["objective_final"]
    runs = {on: r[0] for on, r in runs.items()}
    dev, hst = runs[True].report, runs[False].report
    print({k: (dev[k], hst[k]) for k in ("objective_final", "outer_iterations", "outer_iterations_done", "seconds_loop")})
    assert dev["state_on_gpu"] is True and hst["state_on_gpu"] is False
    assert dev["outer_iterations_done"] == hst["outer_iterations_done"]
    assert dev["objective_final"] == hst["objective_final"]
    apart = 10.0 * float(np.max(np.linalg.norm(np.asarray(runs[True].uv_cm) - np.asarray(runs[False].uv_cm), axis=1)))
    assert apart == 0.0, apart
