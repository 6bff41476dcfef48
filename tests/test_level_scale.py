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


def _stretched_up(body, k: float):
    """The body scaled by k in height about its soles."""
    v = np.array(body.vertices, dtype=float)
    z0 = v[:, 2].min()
    v[:, 2] = z0 + k * (v[:, 2] - z0)
    return replace(body, vertices=v)


def _with_belly(body, depth_m: float):
    """The body with its front pushed forward (-y) between the hip and the bust, most at
    mid-height: a full belly, with no vertex moved up or down."""
    from seamfit.body.measure import body_measurements
    lv = body_measurements(body)["levels_z_m"]
    v = np.array(body.vertices, dtype=float)
    lo, hi = lv["hip"], lv["bust"]
    cy = 0.5 * (v[:, 1].min() + v[:, 1].max())
    s = np.clip((v[:, 2] - lo) / (hi - lo), 0.0, 1.0)
    front = (v[:, 1] < cy) & (s > 0) & (s < 1)
    v[front, 1] -= depth_m * np.sin(np.pi * s[front])
    return replace(body, vertices=v)


def test_a_taller_body_maps_every_level_up_in_proportion():
    from seamfit.body import load_body
    from seamfit.opt.level_scale import level_map
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    zb, zt = level_map(body, _stretched_up(body, 1.05))
    z0 = body.vertices[:, 2].min()
    assert len(zb) == 5                          # soles, crotch, waist, armpit, crown
    assert np.allclose(zt - z0, 1.05 * (zb - z0), atol=1e-6)


def test_levels_follow_the_body_sections_not_the_target_s_own_measurements():
    # A belly moves the narrowest girth (the waist a tape would find) towards the bust;
    # the garment's levels stay with the body sections, which did not move up or down.
    from seamfit.body import load_body
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import level_map
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    bellied = _with_belly(body, 0.06)
    moved = body_measurements(bellied)["levels_z_m"]["waist"] - body_measurements(body)["levels_z_m"]["waist"]
    assert abs(moved) > 0.005                    # the target's own waist rule lands elsewhere
    zb, zt = level_map(body, bellied)
    assert np.max(np.abs(zt - zb)) < 1e-9


def test_a_skirt_passes_the_crotch_as_one_tube(skirt):
    from seamfit.opt.level_scale import passes_crotch_as_one_tube
    mesh, xbar, body, sdf = skirt
    assert passes_crotch_as_one_tube(mesh, xbar, body)
    # Cut off below the hip, the same garment ends above the crotch: it passes nothing.
    top = xbar.copy()
    top[:, 2] = np.maximum(top[:, 2], body.vertices[:, 2].max() * 0.55)
    assert not passes_crotch_as_one_tube(mesh, top, body)
