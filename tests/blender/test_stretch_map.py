# SPDX-License-Identifier: GPL-3.0-or-later
"""The stretch map: its colour range comes from the data (or the user), a legend shows the
range in the viewport and in renders, principal strains are stored in %, and the garment is
drawn outside the body even at a coarse mesh."""
import bpy
import numpy as np
import pytest
from mathutils.bvhtree import BVHTree

from helpers import addon, scene_for


@pytest.fixture()
def draped(scene):
    s = scene_for(scene, 4.0, 5.0)
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "drape"]
    (garment,) = [o for o in coll.objects if o.type == "MESH" and "stretch_ratio" in o.data.attributes]
    return s, coll, garment


def _point_values(obj, name, count=None):
    v = np.empty(count or len(obj.data.vertices), dtype=np.float32)
    obj.data.attributes[name].data.foreach_get("value", v)
    return v.astype(np.float64)


def _colors(obj):
    c = np.empty(4 * len(obj.data.vertices), dtype=np.float32)
    obj.data.color_attributes["stretch_color"].data.foreach_get("color", c)
    return c.reshape(-1, 4)


def test_colour_range_comes_from_the_data(draped):
    s, coll, garment = draped
    strain = 100.0 * (_point_values(garment, "stretch_ratio") - 1.0)
    st = garment["seamfit_stretch"]
    span = st["span_pct"]
    # The smallest round range holding 99 % of the vertices: well under the old fixed 10 %
    # for woven cotton, so the map is not washed out white.
    q99 = np.percentile(np.abs(strain), 99)
    assert q99 <= span and span < 10.0
    assert np.mean(np.abs(strain) <= span) >= 0.99
    assert st["min_pct"] == pytest.approx(strain.min(), abs=1e-4)
    assert st["max_pct"] == pytest.approx(strain.max(), abs=1e-4)
    rgb = _colors(garment)
    i = int(np.argmax(strain))
    t = min(strain[i] / span, 1.0)
    assert rgb[i, :3] == pytest.approx([1.0, 1.0 - t, 1.0 - t], abs=1e-5)
    # A fixed range set by the user recolours the map at once.
    s.stretch_range = "FIXED"
    s.stretch_span_pct = 50.0
    assert garment["seamfit_stretch"]["span_pct"] == 50.0
    assert _colors(garment)[i, :3] == pytest.approx([1.0, 1.0 - strain[i] / 50, 1.0 - strain[i] / 50], abs=1e-5)


def test_legend_in_the_viewport_and_in_renders(draped):
    s, coll, garment = draped
    span = garment["seamfit_stretch"]["span_pct"]
    (item,) = addon().overlay.legend_items(bpy.context.scene)
    assert item["object"] == garment.name and item["span_pct"] == span
    assert item["low"] == f"-{span:g} %" and item["high"] == f"+{span:g} %"
    # The render legend: a colour bar in the result's collection, beside the garment, with
    # its range written on it; it renders with the same material.
    legend = addon().scene_io.legend_of(garment)
    assert legend.name in coll.objects and not legend.hide_render
    assert legend.data.materials[0] == garment.data.materials[0]
    texts = sorted(c.data.body for c in legend.children)
    assert texts == sorted([f"-{span:g} %", f"+{span:g} %", "Edge stretch (%)"])
    bar = _colors(legend)
    assert bar[0, :3] == pytest.approx([0.0, 0.0, 1.0]) and bar[-1, :3] == pytest.approx([1.0, 0.0, 0.0])
    corners = np.array(garment.bound_box) @ np.array(garment.matrix_world)[:3, :3].T
    assert legend.location.x > corners[:, 0].max()
    s.stretch_range = "FIXED"
    s.stretch_span_pct = 25.0
    assert sorted(c.data.body for c in legend.children) == sorted(["-25 %", "+25 %", "Edge stretch (%)"])
    assert addon().overlay.legend_items(bpy.context.scene)[0]["high"] == "+25 %"
    # A re-run that replaces the result keeps garment and legend together.
    s.edge_length_cm = 5.0
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "drape"]
    (garment,) = [o for o in coll.objects if o.type == "MESH" and "stretch_ratio" in o.data.attributes]
    legend = addon().scene_io.legend_of(garment)
    s.stretch_span_pct = 20.0
    assert sorted(c.data.body for c in legend.children) == sorted(["-20 %", "+20 %", "Edge stretch (%)"])
    # Hidden garments have no legend in the viewport.
    garment.hide_set(True)
    assert addon().overlay.legend_items(bpy.context.scene) == []


def test_principal_strains_in_percent(draped):
    s, coll, garment = draped
    me = garment.data
    n = len(me.polygons)
    smax = _point_values(garment, "strain_max_pct", n)
    smin = _point_values(garment, "strain_min_pct", n)
    assert np.all(smax >= smin - 1e-5)
    assert -20 < np.median(smin) <= np.median(smax) < 20     # % of a woven drape, not ratios
    # A face stretched by hand: its strains are its stretch.
    uv = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    x = np.array([[0.0, 0.0, 0.0], [0.12, 0.0, 0.0], [0.0, 0.0, 0.09]])
    fmax, fmin, _ = addon().compute.principal_strains_pct(uv, x, np.array([[0, 1, 2]]))
    assert fmax[0] == pytest.approx(20.0) and fmin[0] == pytest.approx(-10.0)
    # Shown on request, with a legend saying so.
    s.stretch_measure = "PRINCIPAL"
    assert garment["seamfit_stretch"]["measure"] == "PRINCIPAL"
    assert "Largest principal strain (%)" in [c.data.body for c in addon().scene_io.legend_of(garment).children]


def _outside_distances(points, tree):
    d = []
    for p in points:
        loc, normal, _, dist = tree.find_nearest(p)
        d.append(dist if np.dot(np.array(p) - np.array(loc), np.array(normal)) >= 0 else -dist)
    return np.array(d)


def test_garment_drawn_outside_the_body_at_a_coarse_mesh(draped):
    s, coll, garment = draped
    depsgraph = bpy.context.evaluated_depsgraph_get()
    tree = BVHTree.FromObject(s.base_body, depsgraph)
    # The simulation's own flat triangles (4 cm) cut into the body between their vertices...
    me = garment.data
    centres = np.array([p.center for p in me.polygons])
    assert (_outside_distances(centres, tree) < 0).sum() > 0
    # ...but what is drawn stays outside: the modifiers are there to see, the mesh data unchanged.
    assert [m.name for m in garment.modifiers] == list(addon().scene_io.DISPLAY_MODIFIERS)
    ev = garment.evaluated_get(depsgraph)
    em = ev.to_mesh()
    try:
        pts = np.array([v.co for v in em.vertices])
        centres = np.array([p.center for p in em.polygons])
    finally:
        ev.to_mesh_clear()
    assert len(pts) > 4 * len(me.vertices)
    assert _outside_distances(pts, tree).min() >= 0.0
    assert _outside_distances(centres, tree).min() >= 0.0
