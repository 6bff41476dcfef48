# SPDX-License-Identifier: GPL-3.0-or-later
"""Import and export of patterns through the operators."""
import json

import bpy
import numpy as np
import pytest

from helpers import (BODICE, PENCIL, PENCIL_GC_SPEC, addon, bezier_world, file_digest, object_fingerprint,
                     scene_fingerprint, undo, undo_push)


def _read(path):
    from seamfit.pattern import read_sewpat
    return read_sewpat(path)


def _nodes_world(pn) -> np.ndarray:
    """Where a panel's curve points belong: the start of every edge, in outline order."""
    starts = sorted(e.start for e in pn.edges)
    return pn.placement.to_world(pn.outline_cm[starts])


def _pattern_collections():
    return [c for c in bpy.data.collections if "seamfit_pattern" in c]


@pytest.mark.parametrize("path", [PENCIL, BODICE], ids=["gc_pencil_skirt", "fs_bodice"])
def test_import_builds_one_flat_curve_per_panel(scene, path):
    pattern = _read(path)
    assert bpy.ops.seamfit.import_pattern(filepath=str(path)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    assert scene.seamfit.pattern == coll
    assert coll.name == f"{pattern.garment_id} {pattern.body_id}"
    assert coll.name in scene.collection.children
    panels = {o["seamfit_panel"]: o for o in coll.objects if "seamfit_panel" in o}
    assert sorted(panels) == sorted(p.name for p in pattern.panels)
    for pn in pattern.panels:
        obj = panels[pn.name]
        assert obj.type == "CURVE" and obj.data.dimensions == "2D"
        (spline,) = obj.data.splines
        # A Bezier curve with a point at the start of every edge (these patterns have no arcs).
        assert spline.type == "BEZIER" and spline.use_cyclic_u and len(spline.bezier_points) == len(pn.edges)
        # Flat in its own frame, and placed where the pattern puts the panel (float32 curve points).
        co = np.empty(len(spline.bezier_points) * 3)
        spline.bezier_points.foreach_get("co", co)
        assert np.all(co.reshape(-1, 3)[:, 2] == 0.0)
        assert np.allclose(bezier_world(obj), _nodes_world(pn), atol=2e-6)
        # The handles are the edges' control points: lines have vector handles a third along.
        right, left = bezier_world(obj, "handle_right"), bezier_world(obj, "handle_left")
        for j, e in enumerate(sorted(pn.edges, key=lambda e: e.start)):
            p0, p1, c = np.array(e.p0), np.array(e.p1), np.array(e.ctrl).reshape(-1, 2)
            ctrl = {"line": lambda: [p0 + (p1 - p0) / 3, p1 + (p0 - p1) / 3],
                    "quadratic": lambda: [p0 + 2 / 3 * (c[0] - p0), p1 + 2 / 3 * (c[0] - p1)],
                    "cubic": lambda: list(c)}[e.kind]()
            assert np.allclose([right[j], left[(j + 1) % len(pn.edges)]], pn.placement.to_world(np.array(ctrl)),
                               atol=2e-6)
            point = spline.bezier_points[j]
            assert (point.handle_right_type == "VECTOR") == (e.kind == "line")
        assert list(obj["seamfit_corners"]) == pn.corners
        assert obj.show_name
    # The summary the panels draw: names, corners, stitch lengths.
    info = coll.seamfit
    assert [p.name for p in info.panels] == [p.name for p in pattern.panels]
    assert [p.n_corners for p in info.panels] == [len(p.corners) for p in pattern.panels]
    assert len(info.stitches) == len(pattern.stitches)
    for st, it in zip(pattern.stitches, info.stitches):
        assert (it.panel_a, it.panel_b) == (st.a.panel, st.b.panel)
        assert it.length_a_cm == pytest.approx(st.length_a_cm, rel=1e-6)
        assert it.length_b_cm == pytest.approx(st.length_b_cm, rel=1e-6)


def test_stitches_are_loose_sewing_edges(scene):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    pattern = _read(PENCIL)
    (coll,) = _pattern_collections()
    (stitch_obj,) = [o for o in coll.objects if o.type == "MESH"]
    me = stitch_obj.data
    assert len(me.polygons) == 0 and len(me.edges) > 0
    stitch_of_edge = np.empty(len(me.edges), dtype=np.int32)
    me.attributes["stitch"].data.foreach_get("value", stitch_of_edge)
    assert set(stitch_of_edge) == set(range(len(pattern.stitches)))
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    # Each stitch's first edge joins the start of side A to the end of side B (reversed stitch).
    for k, st in enumerate(pattern.stitches):
        e = me.edges[int(np.flatnonzero(stitch_of_edge == k)[0])]
        pa, pb = pattern.panel(st.a.panel), pattern.panel(st.b.panel)
        a0 = pa.placement.to_world(pa.outline_cm[[st.a.range[0]]])[0]
        b_end = pb.placement.to_world(pb.outline_cm[[st.b.range[1] if st.orientation == "reversed"
                                                     else st.b.range[0]]])[0]
        assert np.allclose(co[e.vertices[0]], a0, atol=1e-6)
        assert np.allclose(co[e.vertices[1]], b_end, atol=1e-6)


def test_import_leaves_existing_objects_alone(scene):
    bpy.ops.mesh.primitive_cube_add(location=(1, 2, 3))
    cube = bpy.context.active_object
    before = object_fingerprint(cube)
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    assert object_fingerprint(cube) == before
    colls = _pattern_collections()
    assert len(colls) == 2 and colls[0].name != colls[1].name
    # Object names may be suffixed by Blender, the panel identity is kept on the object.
    assert sorted(o["seamfit_panel"] for o in colls[1].objects if "seamfit_panel" in o) == \
        sorted(o["seamfit_panel"] for o in colls[0].objects if "seamfit_panel" in o)


def test_broken_file_reports_and_changes_nothing(scene, tmp_out):
    bad = tmp_out / "bad.json"
    d = json.loads(PENCIL.read_text())
    del d["panels"][1]["outline_cm"]
    bad.write_text(json.dumps(d))
    before = scene_fingerprint()
    with pytest.raises(RuntimeError, match="outline_cm"):
        bpy.ops.seamfit.import_pattern(filepath=str(bad))
    with pytest.raises(RuntimeError, match="no such file"):
        bpy.ops.seamfit.import_pattern(filepath=str(tmp_out / "missing.json"))
    # Readable but invalid: seamfit's validation names the stitch.
    d = json.loads(PENCIL.read_text())
    d["stitches"][0]["a"]["range"] = [0, 100000]
    bad.write_text(json.dumps(d))
    with pytest.raises(RuntimeError, match="invalid pattern"):
        bpy.ops.seamfit.import_pattern(filepath=str(bad))
    assert scene_fingerprint() == before


def test_export_roundtrip_is_lossless(scene, tmp_out):
    from seamfit.pattern.sewpat import pattern_to_dict
    digest = file_digest(PENCIL)
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    out = tmp_out / "out.json"
    assert bpy.ops.seamfit.export_pattern(filepath=str(out), format="SEWPAT") == {"FINISHED"}
    assert pattern_to_dict(_read(out)) == pattern_to_dict(_read(PENCIL))
    assert file_digest(PENCIL) == digest


def test_export_takes_edits_from_the_curves(scene, tmp_out):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    pattern = _read(PENCIL)
    (coll,) = _pattern_collections()
    pn = pattern.panels[0]
    obj = next(o for o in coll.objects if o.get("seamfit_panel") == pn.name)
    # The corner where two straight edges meet moves 2 cm along u.
    order = sorted(pn.edges, key=lambda e: e.start)
    j = next(j for j in range(len(order)) if order[j].kind == order[j - 1].kind == "line")
    pt = obj.data.splines[0].bezier_points[j]
    pt.co = (pt.co[0] + 0.02, pt.co[1], 0.0)
    obj.location.z += 0.1
    out = tmp_out / "edited.json"
    bpy.ops.seamfit.export_pattern(filepath=str(out), format="SEWPAT")
    edited = _read(out)
    ep = edited.panels[0]
    e = next(x for x in ep.edges if x.id == order[j].id)
    assert np.allclose(ep.outline_cm[e.start], pn.outline_cm[order[j].start] + [2.0, 0.0], atol=1e-4)
    assert edited.panels[0].placement.translation_m[2] == pytest.approx(
        pattern.panels[0].placement.translation_m[2] + 0.1, abs=1e-6)
    for a, b in zip(edited.panels[1:], pattern.panels[1:]):
        assert np.array_equal(a.outline_cm, b.outline_cm)


def test_export_refuses_a_point_added_on_top_of_another(scene, tmp_out):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    (coll,) = _pattern_collections()
    obj = next(o for o in coll.objects if "seamfit_panel" in o)
    pts = obj.data.splines[0].bezier_points
    pts.add(1)
    for attr in ("co", "handle_left", "handle_right"):
        setattr(pts[-1], attr, getattr(pts[0], attr))
    out = tmp_out / "x.json"
    with pytest.raises(RuntimeError, match=rf"panel {obj['seamfit_panel']!r}: added curve point {len(pts) - 1} "
                                           r"\(at .* cm\) is on an end of edge \d+, where a point already is"):
        bpy.ops.seamfit.export_pattern(filepath=str(out), format="SEWPAT")
    assert not out.exists()


def test_export_does_not_clobber_on_failure(scene, tmp_out):
    """A failed export leaves an existing file whole."""
    out = tmp_out / "keep.json"
    out.write_text("precious")
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    (coll,) = _pattern_collections()
    next(o for o in coll.objects if "seamfit_panel" in o).data.splines[0].bezier_points.add(2)
    with pytest.raises(RuntimeError):
        bpy.ops.seamfit.export_pattern(filepath=str(out), format="SEWPAT")
    assert out.read_text() == "precious"


def test_undo_removes_the_import(scene):
    bpy.ops.mesh.primitive_cube_add()
    undo_push("before import")
    before = scene_fingerprint()
    assert "UNDO" in bpy.types.SEAMFIT_OT_import_pattern.bl_options
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    undo_push("Import Sewing Pattern")      # what Blender does after an UNDO operator in the UI
    assert len(_pattern_collections()) == 1
    undo()
    assert _pattern_collections() == []
    assert scene_fingerprint() == before
    assert bpy.context.scene.seamfit.pattern is None


def test_overlay_items(scene):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    pattern = _read(PENCIL)
    items = addon().overlay.overlay_items(scene)
    assert len(items["corners"]) == sum(len(p.corners) for p in pattern.panels)
    first = pattern.panels[0]
    assert np.allclose(items["corners"][0], first.placement.to_world(first.outline_cm[[first.corners[0]]])[0],
                       atol=2e-6)
    assert len(items["labels"]) == len(pattern.stitches)
    assert items["labels"][0][1].startswith(f"{pattern.stitches[0].length_a_cm:.1f}")


def test_presets_set_strengths(scene):
    s = scene.seamfit
    s.strength_preset = "fitted"
    assert (s.strength_dis, s.strength_smo, s.strength_str) == pytest.approx((0.01, 5e-5, 5.0))
    s.strength_pos = 50.0
    assert s.strength_preset == "CUSTOM"
    s.strength_preset = "dress"
    assert s.strength_pos == 100.0 and s.strength_preset == "dress"
    # The presets are seamfit's own (an alias such as bodysuit is listed once).
    from seamfit.opt import PRESETS
    items = {i.identifier for i in s.bl_rna.properties["strength_preset"].enum_items}
    assert items == {k for k, p in PRESETS.items() if p.name == k} | {"CUSTOM"}
    s.strength_preset = "skirt_shirring"
    want = PRESETS["skirt_shirring"].strengths
    assert [getattr(s, f"strength_{k}") for k in ("fix", "cur", "dis", "smo", "str", "pos")] == \
        pytest.approx([want.fix, want.cur, want.dis, want.smo, want.str, want.pos], rel=1e-6)


def test_import_garmentcode_specification(scene):
    from seamfit.pattern import load_pattern
    pattern = load_pattern(PENCIL_GC_SPEC)
    assert bpy.ops.seamfit.import_pattern(filepath=str(PENCIL_GC_SPEC)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    panels = {o["seamfit_panel"]: o for o in coll.objects if "seamfit_panel" in o}
    assert sorted(panels) == sorted(p.name for p in pattern.panels)
    for pn in pattern.panels:
        assert np.allclose(bezier_world(panels[pn.name]), _nodes_world(pn), atol=2e-6)
    assert len(coll.seamfit.stitches) == len(pattern.stitches) > 0


def test_export_svg(scene, tmp_out):
    import xml.etree.ElementTree as ET
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    out = tmp_out / "pattern.svg"
    assert bpy.ops.seamfit.export_pattern(filepath=str(out), format="SVG") == {"FINISHED"}
    root = ET.parse(out).getroot()
    texts = {t.text for t in root.iter("{http://www.w3.org/2000/svg}text")}
    assert {p.name for p in _read(PENCIL).panels} <= texts
    assert root.get("width").endswith("cm")


def test_export_refuses_to_overwrite_the_imported_file(scene, tmp_out):
    src = tmp_out / "mine.json"
    src.write_bytes(PENCIL.read_bytes())
    digest = file_digest(src)
    bpy.ops.seamfit.import_pattern(filepath=str(src))
    with pytest.raises(RuntimeError, match="read from"):
        bpy.ops.seamfit.export_pattern(filepath=str(src), format="SEWPAT")
    assert file_digest(src) == digest
