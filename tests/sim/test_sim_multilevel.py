"""Coarse-to-fine dressing (seamfit.sim.multilevel) and the safeguards of the
stages that follow it: the prolongation through pattern coordinates, a sewn
start that skips the sew stage, and a Newton polish that never hands back more
residual than it was given."""
from __future__ import annotations


import numpy as np
import pytest

from seamfit.body import build_sdf, load_body
from seamfit.mesh import build_sewn_mesh
from seamfit.pattern import load_pattern
from seamfit.sim import Fabric, SimSettings, Simulator
from seamfit.sim.multilevel import COARSENING, coarse_mesh, drape_coarse_to_fine, drape_from_coarse, prolong
from common import SAMPLES



def _pattern(garment: str, body_id: str):
    return load_pattern(SAMPLES / "patterns" / garment / body_id / "pattern.json")


def _sdf(body_id: str, x0):
    body = load_body(SAMPLES / "bodies" / f"women_{body_id}.obj")
    lo, hi = x0.min(axis=0), x0.max(axis=0)
    return build_sdf(body, spacing=0.005, bounds=(-0.6, -0.35, lo[2] - 0.6, 0.6, 0.45, hi[2] + 0.15))


def test_prolong_carries_a_placement_exactly():
    # Each panel's placement is affine in (u, v): the coarse mesh's x0 prolonged
    # to the fine mesh is the fine mesh's x0, up to the outline's curvature
    # between coarse boundary vertices.
    pattern = _pattern("gc_circle_skirt", "size06")
    fine = build_sewn_mesh(pattern, 3.0)
    coarse = build_sewn_mesh(pattern, 3.0 * COARSENING)
    x = prolong(coarse, coarse.x0, fine)
    err = np.linalg.norm(x - fine.x0, axis=1)
    assert x.shape == fine.x0.shape and np.all(np.isfinite(x))
    assert np.median(err[~fine.boundary]) < 1e-9
    assert err.max() < 0.01  # sagitta of a 6 cm chord on the skirt's waist arc


def test_prolong_rejects_another_pattern():
    a = build_sewn_mesh(_pattern("gc_circle_skirt", "size06"), 6.0)
    b = build_sewn_mesh(_pattern("gc_pencil_skirt", "size06"), 6.0)
    with pytest.raises(Exception, match="same pattern"):
        prolong(a, a.x0, b)


def test_circle_skirt_dresses_coarse_to_fine():
    pattern = _pattern("gc_circle_skirt", "size06")
    mesh = build_sewn_mesh(pattern, 3.0)
    sdf = _sdf("size06", mesh.x0)
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(max_seconds=60))
    res = drape_from_coarse(sim, pattern, coarse_mesh(pattern, mesh))
    names = [s["stage"] for s in res.stages]
    assert names[0] == "coarse sew" and "prolonged settle" in names
    assert "sew" not in names  # the prolonged drape is already sewn
    assert res.converged, res.message
    assert res.max_sewing_gap_mm <= 2.0 and res.min_phi_mm >= -1.0
    assert np.all(np.isfinite(res.x)) and res.x.shape == mesh.x0.shape
    assert res.iterations == sum(s["iterations"] for s in res.stages)


def test_newton_never_returns_more_residual_than_it_started_with():
    # A few Newton steps from an unsettled start may raise the residual (the
    # line search lowers the energy); the polish keeps the best state.
    pattern = _pattern("gc_circle_skirt", "size06")
    mesh = build_sewn_mesh(pattern, 6.0)
    sdf = _sdf("size06", mesh.x0)
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(polish=False, max_iterations=3000, sew_first=True))
    start = sim.drape(mesh.x0).x
    r0 = sim.residual(start)
    for n in (1, 2, 4, 8):
        res = sim.solve(start, method="newton", max_iterations=n, tolerance=1e-12)
        assert res.residual <= r0 * (1 + 1e-9), res.message
        assert np.isclose(res.residual, sim.residual(res.x), rtol=1e-9)
        assert np.all(np.isfinite(res.x))


def test_a_garment_that_settles_is_not_restarted():
    pattern = _pattern("fs_bodice", "size06")
    mesh = build_sewn_mesh(pattern, 3.0)
    sdf = _sdf("size06", mesh.x0)
    res = drape_coarse_to_fine(Simulator(mesh, sdf, Fabric(), SimSettings(max_seconds=60)), pattern)
    assert res.converged, res.message
    assert not any(s["stage"].startswith("coarse") for s in res.stages)


def test_restart_never_hands_back_more_than_the_first_settle():
    # A budget too small for anything to converge: the restart from the coarse
    # mesh ends above the first settle, which is handed back.
    pattern = _pattern("gc_circle_skirt", "size06")
    mesh = build_sewn_mesh(pattern, 3.0)
    sdf = _sdf("size06", mesh.x0)
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(max_iterations=400, chunk=200, polish_iterations=2))
    res = drape_coarse_to_fine(sim, pattern)
    assert not res.converged
    first = next(s for s in res.stages if s["stage"] == "settle")
    assert res.residual <= first["residual"] * (1 + 1e-9)
    assert np.isclose(res.residual, sim.residual(res.x), rtol=1e-6)
    assert any(s["stage"].startswith("coarse") for s in res.stages)
