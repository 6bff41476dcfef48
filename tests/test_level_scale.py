"""The measurement-aware start (seamfit.opt.level_scale): equal bodies give the base pattern
back; a body grown around its axis grows the pattern's widths by what the body girth grew,
and leaves its lengths."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

SAMPLES = Path(__file__).resolve().parents[1] / "sample_files"


@pytest.fixture(scope="module")
def skirt():
    from seamfit.body import build_sdf, load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.opt.grade import base_drape
    from seamfit.pattern import load_pattern
    from seamfit.sim.model import Fabric, SimSettings

    pattern = load_pattern(SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json")
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    mesh = build_sewn_mesh(pattern, edge_length_cm=4.0)
    sdf = build_sdf(body, spacing=0.005)
    xbar, _ = base_drape(mesh, pattern, body, sdf, Fabric(), SimSettings())
    return mesh, xbar, body, sdf


def _widened(body, k: float):
    """The body scaled by k across (x, y) about its vertical axis; heights unchanged."""
    v = np.array(body.vertices, dtype=float)
    c = 0.5 * (v[:, :2].min(axis=0) + v[:, :2].max(axis=0))
    v[:, :2] = c + k * (v[:, :2] - c)
    return replace(body, vertices=v)


def test_equal_bodies_give_the_base_pattern(skirt):
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    p = level_scaled_pattern(mesh, xbar, body, body, sdf)
    assert np.max(np.abs(p - 0.01 * mesh.uv_cm)) < 1e-9


def test_widths_grow_by_the_girth_the_garment_encloses(skirt):
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    k = 1.06
    target = _widened(body, k)
    p = level_scaled_pattern(mesh, xbar, body, target, sdf)
    assert np.all(np.isfinite(p))
    hip_growth_cm = body_measurements(target)["hip"] - body_measurements(body)["hip"]
    # The two skirt panels go once around the body: their widths together grow by what
    # the hip grew (their hems hang from it), and their lengths stay.
    grow_w, grow_h = 0.0, []
    vp = np.asarray(mesh.vertex_panel)
    for i, name in enumerate(mesh.panel_names):
        if not name.startswith("skirt"):
            continue
        a, b = mesh.uv_cm[vp == i], 100.0 * p[vp == i]
        grow_w += np.ptp(b[:, 0]) - np.ptp(a[:, 0])
        grow_h.append(np.ptp(b[:, 1]) - np.ptp(a[:, 1]))
    assert grow_w == pytest.approx(hip_growth_cm, rel=0.2)
    assert max(abs(h) for h in grow_h) < 0.5
