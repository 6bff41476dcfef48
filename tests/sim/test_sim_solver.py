"""The quasistatic solvers on small synthetic garments: energy decreases, the
force residual falls under the tolerance, both solvers reach the same
equilibrium, seams close around a body with nothing inside it, and budgets,
cancellation and callback errors are reported, never NaN."""
from __future__ import annotations

import numpy as np
import pytest

from seamfit.errors import SolveError
from seamfit.sim import Fabric, SimSettings, Simulator

from sim_helpers import flat_sheet, hourglass_sdf, sewn_tube


@pytest.fixture(scope="module")
def body():
    return hourglass_sdf(spacing=0.01)


def hanging_sheet(**settings):
    mesh = flat_sheet(width_cm=20, height_cm=20, nu=8, nv=8, jitter=0.2)
    # Stand the sheet up in the x-z plane and pin its top corners.
    mesh.x0 = np.c_[mesh.x0[:, 0], np.zeros(len(mesh.x0)), mesh.x0[:, 1]]
    sim = Simulator(mesh, None, Fabric(), SimSettings(sew_first=False, **settings))
    top = np.flatnonzero(mesh.uv_cm[:, 1] > 19.99)
    corners = top[[np.argmin(mesh.uv_cm[top, 0]), np.argmax(mesh.uv_cm[top, 0])]]
    sim.set_sticking(corners, mesh.x0[corners], stiffness=200.0)
    return mesh, sim


@pytest.mark.parametrize("method", ["chebyshev", "newton"])
def test_hanging_sheet_converges_and_lowers_energy(method):
    mesh, sim = hanging_sheet(method=method, tolerance=1e-4, max_iterations=60000)
    e0, t0 = sim.energy(mesh.x0)
    res = sim.drape()
    assert res.converged, res.message
    assert res.residual <= 1e-4
    assert sim.residual(res.x) == pytest.approx(res.residual, rel=1e-9)
    assert res.energy_terms["gravity"] < t0["gravity"]
    e1 = sum(res.energy_terms.values())
    assert e1 < e0
    assert np.all(np.isfinite(res.x))
    # It hangs: everything below the pins.
    assert res.x[:, 2].max() <= mesh.x0[:, 2].max() + 1e-3


def test_both_solvers_reach_the_same_equilibrium():
    mesh, cheb = hanging_sheet(method="chebyshev", tolerance=1e-6, max_iterations=200000)
    _, newton = hanging_sheet(method="newton", tolerance=1e-9)
    a = cheb.drape()
    b = newton.drape()
    assert a.converged and b.converged, (a.message, b.message)
    assert np.abs(a.x - b.x).max() < 1e-4  # 0.1 mm


def test_iterate_is_a_fixed_number_of_chebyshev_iterations():
    # The search's inexact steps: the solve's iterations without the DrapeResult summary,
    # and the residual it reports is the one of the state it returns.
    mesh, sim = hanging_sheet(method="chebyshev")
    x, rep = sim.iterate(mesh.x0, 40)
    ref = sim.solve(mesh.x0, tolerance=1e-12, max_iterations=40)
    assert rep["iterations"] == 40 and not rep["converged"]
    np.testing.assert_array_equal(x, ref.x)
    assert rep["residual"] == pytest.approx(sim.residual(x), rel=1e-9)
    np.testing.assert_array_equal(mesh.x0, sim.iterate(mesh.x0, 0)[0])


def test_chebyshev_energy_checkpoints_never_rise():
    mesh, sim = hanging_sheet(tolerance=1e-5, max_iterations=3000, check_every=8, history_every=0)
    x = mesh.x0
    energies = []
    for _ in range(6):
        res = sim.solve(x, max_iterations=500)
        x = res.x
        energies.append(sum(res.energy_terms.values()))
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(energies, energies[1:]))


@pytest.mark.parametrize("method", ["chebyshev", "newton"])
def test_tube_dresses_the_body(body, method):
    mesh = sewn_tube(radius_m=0.12, height_cm=30, nu=14, nv=8, gap_m=0.05, z0=0.2, ease=1.1)
    settings = SimSettings(method=method, tolerance=1e-3, max_iterations=60000 if method == "chebyshev" else 600)
    sim = Simulator(mesh, body, Fabric(), settings)
    gap0 = sim.sewing_gaps(mesh.x0).max()
    assert gap0 > 0.2  # panels start 0.34 m apart
    res = sim.drape()
    assert res.converged, res.message
    assert res.max_sewing_gap_mm <= 2.0
    assert res.min_phi_mm >= -1.0
    assert np.all(np.isfinite(res.x))
    # It rests on the hips (the body's radius there exceeds the tube's) and
    # closes around the body: vertices all around the axis.
    ang = np.arctan2(res.x[:, 1], res.x[:, 0])
    assert np.histogram(ang, bins=12, range=(-np.pi, np.pi))[0].min() > 0
    assert res.x[:, 2].min() > -0.3
    assert [s["stage"] for s in res.stages] == ["sew", "settle"]


def test_progress_callback_and_cancel(body):
    mesh = sewn_tube(radius_m=0.12, height_cm=30, nu=10, nv=6, gap_m=0.05, z0=0.2)
    sim = Simulator(mesh, body, Fabric(), SimSettings(progress_every=10, tolerance=1e-9, max_iterations=5000))
    seen = []

    def cb(it, res):
        seen.append((it, res))
        return it < 100

    res = sim.drape(progress=cb)
    assert res.cancelled and not res.converged
    assert "cancelled" in res.message
    assert seen and seen[-1][0] >= 100
    assert all(np.isfinite(r) for _, r in seen)
    assert np.all(np.isfinite(res.x))

    def bad(it, res):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        sim.drape(progress=bad)


def test_budget_exhaustion_is_reported(body):
    mesh = sewn_tube(radius_m=0.12, height_cm=30, nu=10, nv=6, gap_m=0.05, z0=0.2)
    sim = Simulator(mesh, body, Fabric(), SimSettings(tolerance=1e-12, max_iterations=50, sew_first=False,
                                                      polish=False))
    res = sim.drape()
    assert not res.converged and not res.cancelled
    assert "not converged" in res.message and "iteration budget" in res.message
    assert res.iterations == 50
    # With the Newton polish, its own budget follows.
    sim.settings.polish = True
    sim.settings.polish_iterations = 7
    res = sim.drape()
    assert [s["stage"] for s in res.stages] == ["settle", "polish"]
    assert res.stages[1]["iterations"] == 7 and res.iterations == 57 and not res.converged
    assert np.all(np.isfinite(res.x)) and np.isfinite(res.residual)
    sim2 = Simulator(mesh, body, Fabric(), SimSettings(tolerance=1e-12, max_seconds=0.05, max_iterations=10**9,
                                                       sew_first=False))
    res2 = sim2.drape()
    assert not res2.converged and "time budget" in res2.message


def test_bad_inputs_raise_solve_error(body):
    mesh = sewn_tube(nu=4, nv=3)
    with pytest.raises(SolveError, match="method"):
        Simulator(mesh, body, settings=SimSettings(method="leapfrog"))
    with pytest.raises(SolveError, match="fabric"):
        Simulator(mesh, body, fabric=Fabric(density=float("nan")))
    sim = Simulator(mesh, body)
    with pytest.raises(SolveError, match="non-finite"):
        x = mesh.x0.copy(); x[3, 1] = np.nan
        sim.drape(x)
    with pytest.raises(SolveError, match="rows"):
        sim.drape(mesh.x0[:5])
    bad = sewn_tube(nu=4, nv=3)
    bad.triangles = bad.triangles.copy(); bad.triangles[0, 0] = 10**6
    with pytest.raises(SolveError, match="out of range"):
        Simulator(bad, body)
