"""Real sample garments dress their own bodies: seams closed, nothing inside the
body, residual under the threshold. Coarse meshes (3 cm edges) and a 5 mm SDF
around the garment keep the file quick; docs/dress_results.md has every shared
pattern on its own body at the default resolution (tests/benchmarks/bench_dress.py)."""
from __future__ import annotations


import numpy as np
import pytest

from seamfit.body import build_sdf, load_body
from seamfit.mesh import build_sewn_mesh
from seamfit.pattern import load_pattern
from seamfit.sim import Fabric, SimSettings, Simulator
from seamfit.sim.dressing import initial_positions
from common import SAMPLES

BODIES = {"size06": "women_size06", "size10": "women_size10", "apple": "women_apple"}


def dress(garment: str, body_id: str, method: str = "chebyshev"):
    pattern = load_pattern(SAMPLES / "patterns" / garment / body_id / "pattern.json")
    mesh = build_sewn_mesh(pattern, 3.0)
    body = load_body(SAMPLES / "bodies" / f"{BODIES[body_id]}.obj")
    lo = mesh.x0.min(axis=0)
    hi = mesh.x0.max(axis=0)
    bounds = (-0.6, -0.35, lo[2] - 0.25, 0.6, 0.45, hi[2] + 0.15)
    sdf = build_sdf(body, spacing=0.005, bounds=bounds)
    x0, info = initial_positions(mesh, pattern, sdf)
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(method=method, max_seconds=60))
    return mesh, sim, x0, info, sim.drape(x0)


@pytest.mark.parametrize("garment,body_id", [("gc_pencil_skirt", "apple"), ("fs_bodice", "size10")])
def test_sample_garment_dresses_its_body(garment, body_id):
    mesh, sim, x0, info, res = dress(garment, body_id)
    assert res.converged, res.message
    assert res.residual <= 1e-3
    assert res.max_sewing_gap_mm <= 2.0
    assert res.min_phi_mm >= -1.0
    assert np.all(np.isfinite(res.x))
    # The seams started open (panels apart) and were closed by the simulation.
    assert sim.sewing_gaps(x0).max() > 0.05
    # It hangs on the body: nothing fell below the start placement by more than
    # a few centimetres, and the garment surrounds the body's axis.
    assert res.x[:, 2].min() > x0[:, 2].min() - 0.1
    ang = np.arctan2(res.x[:, 1] - 0.06, res.x[:, 0])
    assert np.histogram(ang, bins=8, range=(-np.pi, np.pi))[0].min() > 0
    if garment.startswith("fs_"):
        assert info["wrapped_panels"]  # hint placements were wrapped first
