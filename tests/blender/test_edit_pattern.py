# SPDX-License-Identifier: GPL-3.0-or-later
"""Editable patterns: panels are Bezier curves; moved points and handles go back into the
pattern with its stitches kept on their edges, are validated like files, and re-grade."""
import bpy
import numpy as np
import pytest

from helpers import BODICE, PENCIL, SAMPLES, addon, file_digest, scene_fingerprint, undo, undo_push

CIRCLE = SAMPLES / "patterns" / "gc_circle_skirt" / "size06" / "pattern.json"


def _read(path):
    from seamfit.pattern import load_pattern
    return load_pattern(path)


def _pattern_dict(pattern):
    from seamfit.pattern.sewpat import pattern_to_dict
    return pattern_to_dict(pattern)


def _imported(path):
    assert bpy.ops.seamfit.import_pattern(filepath=str(path)) == {"FINISHED"}
    coll = bpy.context.scene.seamfit.pattern
    return coll, addon().scene_io.panel_objects(coll)


def _order(pn):
    return sorted(pn.edges, key=lambda e: e.start)


def _point_of(obj, edge_id):
    """The Bezier point where an edge starts."""
    return obj.data.splines[0].bezier_points[list(obj["seamfit_segments"]).index(edge_id)]


def _stitch_edges(pattern):
    """Each stitch side as the (edge at its first point, edge at its last point) of its panel."""
    def at(panel, i):
        return next(e.id for e in panel.edges if e.start == i)
    return [(side.panel, at(pattern.panel(side.panel), side.range[0]), at(pattern.panel(side.panel), side.range[1]))
            for s in pattern.stitches for side in (s.a, s.b)]


@pytest.mark.parametrize("path", [PENCIL, BODICE, CIRCLE], ids=["lines+quadratics", "cubics", "arcs"])
def test_unchanged_curves_read_back_losslessly(scene, path):
    coll, objs = _imported(path)
    original = _read(path)
    if path == CIRCLE:      # an arc of more than a quarter turn is drawn with one segment per quarter
        pn = next(p for p in original.panels if any(e.kind == "arc" for e in p.edges))
        assert len(objs[pn.name].data.splines[0].bezier_points) > len(pn.edges)
    back = addon().scene_io.pattern_from_collection(coll)
    for a, b in zip(back.panels, original.panels):
        assert np.abs(a.outline_cm - b.outline_cm).max() <= 1e-9
    assert _pattern_dict(back) == _pattern_dict(original)
    # Applying no edits changes nothing.
    before = scene_fingerprint()
    stored = coll["seamfit_pattern"]
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    assert coll["seamfit_pattern"] == stored and scene_fingerprint() == before


def test_moved_point_and_handle_go_back_into_the_pattern(scene, tmp_out):
    digest = file_digest(PENCIL)
    coll, objs = _imported(PENCIL)
    original = _read(PENCIL)
    pn = next(p for p in original.panels if any(e.kind == "quadratic" for e in p.edges))
    obj = objs[pn.name]
    order = _order(pn)
    # A corner between two straight edges moves 1 cm along u, the first handle of a
    # quadratic edge 1 cm along u and 0.5 cm along v (1 Blender unit = 1 m).
    j = next(j for j in range(len(order)) if order[j].kind == order[j - 1].kind == "line")
    corner, moved_lines = order[j], (order[j - 1].id, order[j].id)
    quad = next(e for e in order if e.kind == "quadratic")
    point = _point_of(obj, corner.id)
    point.co = (point.co[0] + 0.01, point.co[1], 0.0)
    handle = _point_of(obj, quad.id)
    handle.handle_right = (handle.handle_right[0] + 0.01, handle.handle_right[1] + 0.005, 0.0)

    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    edited = addon().scene_io.pattern_from_collection(coll)
    ep = edited.panel(pn.name)
    edges = {e.id: e for e in ep.edges}
    # The corner moved and the edges meeting there stay straight, through it.
    assert np.allclose(edges[corner.id].p0, np.array(corner.p0) + [1.0, 0.0], atol=1e-4)
    assert np.allclose(ep.outline_cm[edges[corner.id].start], np.array(corner.p0) + [1.0, 0.0], atol=1e-4)
    assert edges[moved_lines[0]].kind == edges[moved_lines[1]].kind == "line"
    assert np.allclose(edges[moved_lines[0]].p1, edges[corner.id].p0)
    # The quadratic became the cubic its handles now make: one handle moved, the other exact.
    q0, q1, qc = (np.array(v) for v in (quad.p0, quad.p1, quad.ctrl[0]))
    e = edges[quad.id]
    assert e.kind == "cubic"
    assert np.allclose(e.ctrl[0], q0 + 2 / 3 * (qc - q0) + [1.0, 0.5], atol=1e-4)
    assert np.array_equal(e.ctrl[1], q1 + 2 / 3 * (qc - q1))
    # The outline follows the edited curves (samples on the curve, at most 1 cm apart).
    from seamfit.pattern import curves
    idx = (e.start + np.arange((e.end - e.start) % ep.n_vertices + 1)) % ep.n_vertices
    assert curves.distance_to_curve(e, ep.outline_cm[idx[:-1]]).max() < 1e-6    # the end is the next edge's
    assert np.linalg.norm(np.diff(ep.outline_cm[idx], axis=0), axis=1).max() <= 1.0 + 1e-9
    # Every other edge of the panel and every other panel are exactly as they were.
    for old in pn.edges:
        if old.id not in (quad.id, *moved_lines):
            new = edges[old.id]
            assert (new.kind, new.p0, new.p1, new.ctrl) == (old.kind, old.p0, old.p1, old.ctrl)
    for a, b in zip(edited.panels, original.panels):
        if a.name != pn.name:
            assert np.array_equal(a.outline_cm, b.outline_cm) and a.edges == b.edges
    # Stitches stay on their edges; the stitch on the quadratic edge has its new length.
    assert len(edited.stitches) == len(original.stitches)
    assert _stitch_edges(edited) == _stitch_edges(original)
    on_quad = [k for k, s in enumerate(original.stitches)
               if any(sd.panel == pn.name and sd.range[0] == quad.start for sd in (s.a, s.b))]
    assert on_quad
    for k in on_quad:
        s0, s1 = original.stitches[k], edited.stitches[k]
        side = "a" if s0.a.panel == pn.name and s0.a.range[0] == quad.start else "b"
        assert getattr(s1, f"length_{side}_cm") != pytest.approx(getattr(s0, f"length_{side}_cm"), abs=1e-3)
    # Held in the scene: the panel list and the stitch lengths follow, and reading the
    # redrawn curves gives the same pattern; the pattern file is untouched.
    assert coll.seamfit.panels[pn.name].n_vertices == ep.n_vertices
    assert _pattern_dict(addon().scene_io.pattern_from_collection(coll)) == _pattern_dict(edited)
    assert file_digest(PENCIL) == digest
    with pytest.raises(RuntimeError, match="refus|overwrit|same file"):
        bpy.ops.seamfit.export_pattern(filepath=str(PENCIL), format="SEWPAT")
    out = tmp_out / "edited.json"
    assert bpy.ops.seamfit.export_pattern(filepath=str(out), format="SEWPAT") == {"FINISHED"}
    assert _pattern_dict(_read(out)) == _pattern_dict(edited)
    assert file_digest(PENCIL) == digest


def test_undo_takes_the_applied_edits_back(scene):
    coll, objs = _imported(PENCIL)
    name, stored = coll.name, coll["seamfit_pattern"]
    pn = _read(PENCIL).panels[0]
    point = objs[pn.name].data.splines[0].bezier_points[0]
    point.co = (point.co[0] + 0.01, point.co[1], 0.0)
    undo_push("moved a point")
    edited = scene_fingerprint()
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    assert coll["seamfit_pattern"] != stored
    undo_push("Apply Curve Edits")
    undo()
    assert bpy.data.collections[name]["seamfit_pattern"] == stored and scene_fingerprint() == edited


def test_moved_arc_ends_keep_it_an_arc(scene):
    coll, objs = _imported(CIRCLE)
    original = _read(CIRCLE)
    pn = next(p for p in original.panels if any(e.kind == "arc" for e in p.edges))
    arc = next(e for e in pn.edges if e.kind == "arc")
    point = _point_of(objs[pn.name], arc.id)
    for attr in ("co", "handle_left", "handle_right"):      # as Blender moves a point: with its handles
        v = getattr(point, attr)
        setattr(point, attr, (v[0] + 0.01, v[1], 0.0))
    e = next(x for x in addon().scene_io.pattern_from_collection(coll).panel(pn.name).edges if x.id == arc.id)
    assert e.kind == "arc"
    assert np.allclose(e.p0, np.array(arc.p0) + [1.0, 0.0], atol=1e-4) and e.p1 == arc.p1
    assert e.arc["radius"] != arc.arc["radius"]


def test_an_arc_bent_inside_follows_the_drawn_curve(scene):
    from seamfit.pattern import curves
    coll, objs = _imported(CIRCLE)
    pn = next(p for p in _read(CIRCLE).panels if any(e.kind == "arc" for e in p.edges))
    arc = next(e for e in pn.edges if e.kind == "arc")
    owner = list(objs[pn.name]["seamfit_segments"])
    inner = owner.index(arc.id) + 1                    # the point between its two quarter turns
    assert owner[inner] == arc.id
    point = objs[pn.name].data.splines[0].bezier_points[inner]
    centre = 0.01 * np.array(arc.arc["center"])
    out = (np.array(point.co[:2]) - centre) / np.linalg.norm(np.array(point.co[:2]) - centre)
    for attr in ("co", "handle_left", "handle_right"):  # 1 cm outwards, with its handles
        v = np.array(getattr(point, attr)[:2]) + 0.01 * out
        setattr(point, attr, (*v, 0.0))
    back = addon().scene_io.pattern_from_collection(coll).panel(pn.name)
    e = next(x for x in back.edges if x.id == arc.id)
    assert e.kind in ("arc", "cubic")
    assert curves.distance_to_curve(e, [100.0 * np.array(point.co[:2])])[0] < 0.05
    assert curves.length(e) > curves.length(arc) + 0.5


def test_self_intersecting_edit_is_one_line_naming_the_panel(scene, tmp_out):
    coll, objs = _imported(PENCIL)
    pn = _read(PENCIL).panels[0]
    obj = objs[pn.name]
    # A corner dragged through the panel to beyond its far side.
    pts = obj.data.splines[0].bezier_points
    co = np.array([p.co[:2] for p in pts])
    far = int(np.argmax(np.linalg.norm(co - co[0], axis=1)))
    pts[0].co = (*(co[0] + 1.2 * (co[far] - co[0])), 0.0)
    before = scene_fingerprint()
    for op in (bpy.ops.seamfit.apply_edits, lambda: bpy.ops.seamfit.export_pattern(
            filepath=str(tmp_out / "never.json"), format="SEWPAT")):
        with pytest.raises(RuntimeError) as info:
            op()
        message = str(info.value).strip()
        assert "\n" not in message
        assert f"panel {pn.name!r}" in message and "self-intersecting" in message
    assert scene_fingerprint() == before
    assert not (tmp_out / "never.json").exists()


def test_an_edited_curve_regrades(grading_scene):
    """Done when: an edited curve re-grades; what the edit did not change is reused."""
    from seamfit import cache as disk
    s = grading_scene
    cache, solve = addon().cache.CACHE, addon().solve
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    first = solve.last_result("adjust")
    entries = {p for p, _, _ in disk.cache_entries()}
    body_hits = cache.hits["body"]
    # Half a centimetre sideways on a handle of a quadratic edge (a curve of the hip line).
    pattern = _read(PENCIL)
    pn = next(p for p in pattern.panels if any(e.kind == "quadratic" for e in p.edges))
    quad = next(e for e in pn.edges if e.kind == "quadratic")
    handle = _point_of(addon().scene_io.panel_objects(s.pattern)[pn.name], quad.id)
    handle.handle_right = (handle.handle_right[0] + 0.005, handle.handle_right[1], 0.0)
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    second = solve.last_result("adjust")
    from seamfit.pattern.sewpat import pattern_from_dict
    import json
    base = pattern_from_dict(json.loads(second.base_pattern_json))
    assert next(e for e in base.panel(pn.name).edges if e.id == quad.id).kind == "cubic"
    assert second.pattern_json != first.pattern_json
    assert cache.misses["grade"] == 2
    # One result, replaced; the bodies and their distance fields were reused, only the base
    # garment was draped again (it is keyed by the pattern).
    graded = [c for c in bpy.data.collections if c.seamfit.role == "graded"]
    assert len(graded) == 1
    assert cache.hits["body"] > body_hits
    new = {p for p, _, _ in disk.cache_entries()} - entries
    assert new and all(p.parent.name == "drape" for p in new)
    assert second.report["base_drape"]["cached"] is False


def _edit_points(obj, points, op):
    """Select the curve points ``points`` in edit mode and run a curve operator, as an artist does."""
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    for i, p in enumerate(obj.data.splines[0].bezier_points):
        p.select_control_point = p.select_left_handle = p.select_right_handle = i in points
    assert op() == {"FINISHED"}
    bpy.ops.object.mode_set(mode="OBJECT")


def _add_point(obj, edge_id):
    """Subdivide the segment an edge is drawn with: a new point in its middle, the curve kept."""
    j = list(obj["seamfit_segments"]).index(edge_id)
    _edit_points(obj, (j, j + 1), lambda: bpy.ops.curve.subdivide(number_cuts=1))
    return j + 1


def _stitched_edge(pattern, kind):
    """A panel and an edge of that kind which a stitch side covers whole."""
    return next((pn, e) for pn in pattern.panels for e in _order(pn) if e.kind == kind and any(
        side.panel == pn.name and side.range == (e.start, e.end) for s in pattern.stitches for side in (s.a, s.b)))


def _side_lengths(pattern, name):
    from seamfit.pattern import range_indices
    pn = pattern.panel(name)
    return [float(np.linalg.norm(np.diff(pn.outline_cm[range_indices(side.range, pn.n_vertices)], axis=0),
                                 axis=1).sum()) for s in pattern.stitches for side in (s.a, s.b) if side.panel == name]


def test_an_added_point_splits_its_edge_and_keeps_its_stitches(scene):
    from seamfit.pattern import curves, validate_pattern
    coll, objs = _imported(PENCIL)
    original = _read(PENCIL)
    pn, e = _stitched_edge(original, "line")
    obj = objs[pn.name]
    k = len(obj.data.splines[0].bezier_points)
    _add_point(obj, e.id)
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    edited = addon().scene_io.pattern_from_collection(coll)
    assert validate_pattern(edited).ok
    ep = edited.panel(pn.name)
    new_id = max(x.id for x in pn.edges) + 1
    edges = {x.id: x for x in ep.edges}
    assert sorted(edges) == sorted([x.id for x in pn.edges] + [new_id])
    first, second = edges[e.id], edges[new_id]
    assert first.kind == second.kind == "line" and first.end == second.start
    assert np.allclose(first.p0, e.p0, atol=1e-4) and np.allclose(second.p1, e.p1, atol=1e-4)
    assert np.allclose(first.p1, 0.5 * (np.array(e.p0) + np.array(e.p1)), atol=1e-4)
    assert curves.distance_to_curve(e, ep.outline_cm[[first.start, second.start, second.end]]).max() < 1e-4
    # The stitches sew the same stretches: the same lengths within 1 mm, the same ends.
    assert np.allclose(_side_lengths(edited, pn.name), _side_lengths(original, pn.name), atol=0.1)
    for s0, s1 in zip(original.stitches, edited.stitches):
        for a, b in ((s0.a, s1.a), (s0.b, s1.b)):
            p0, p1 = original.panel(a.panel), edited.panel(b.panel)
            assert np.allclose(p1.outline_cm[list(b.range)], p0.outline_cm[list(a.range)], atol=1e-3)
    # Drawn again with the new point: reading back changes nothing more.
    assert len(obj.data.splines[0].bezier_points) == k + 1
    assert list(obj["seamfit_segments"]).count(new_id) == 1
    assert _pattern_dict(addon().scene_io.pattern_from_collection(coll)) == _pattern_dict(edited)



def test_an_added_point_on_an_arc_splits_it_into_two_arcs(scene):
    coll, objs = _imported(CIRCLE)
    original = _read(CIRCLE)
    pn, e = _stitched_edge(original, "arc")
    _add_point(objs[pn.name], e.id)                 # in its first quarter turn
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    edited = addon().scene_io.pattern_from_collection(coll)
    edges = {x.id: x for x in edited.panel(pn.name).edges}
    first, second = edges[e.id], edges[max(x.id for x in pn.edges) + 1]
    assert first.kind == second.kind == "arc" and first.end == second.start
    for half in (first, second):
        assert np.allclose(half.arc["center"], e.arc["center"], atol=0.05)
        assert half.arc["radius"] == pytest.approx(e.arc["radius"], abs=0.05)
    assert np.allclose(_side_lengths(edited, pn.name), _side_lengths(original, pn.name), atol=0.1)

def test_a_deleted_plain_point_joins_its_edges(scene):
    coll, objs = _imported(PENCIL)
    original = _read(PENCIL)
    pn, e = _stitched_edge(original, "line")
    obj = objs[pn.name]
    j = _add_point(obj, e.id)
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    _edit_points(obj, (j,), lambda: bpy.ops.curve.delete(type="VERT"))
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    back = addon().scene_io.pattern_from_collection(coll)
    bp = back.panel(pn.name)
    assert sorted(x.id for x in bp.edges) == sorted(x.id for x in pn.edges)
    joined = next(x for x in bp.edges if x.id == e.id)
    assert joined.kind == "line"
    assert np.allclose(joined.p0, e.p0, atol=1e-4) and np.allclose(joined.p1, e.p1, atol=1e-4)
    assert _stitch_edges(back) == _stitch_edges(original)
    assert np.allclose(_side_lengths(back, pn.name), _side_lengths(original, pn.name), atol=0.1)
    assert len(obj.data.splines[0].bezier_points) == len(list(obj["seamfit_segments"]))


def test_a_deleted_stitch_end_is_refused_in_one_line(scene):
    from seamfit.pattern.points import point_roles
    coll, objs = _imported(PENCIL)
    original = _read(PENCIL)
    pn, e = _stitched_edge(original, "line")
    assert any("stitch" in r for r in point_roles(original, pn.name, e.start))
    obj = objs[pn.name]
    j = list(obj["seamfit_segments"]).index(e.id)
    _edit_points(obj, (j,), lambda: bpy.ops.curve.delete(type="VERT"))
    stored = coll["seamfit_pattern"]
    before = scene_fingerprint()
    with pytest.raises(RuntimeError) as info:
        bpy.ops.seamfit.apply_edits()
    message = str(info.value).strip()
    assert "\n" not in message
    assert f"panel {pn.name!r}: curve point {j} " in message and "cannot be deleted: it is an end of stitch" in message
    assert coll["seamfit_pattern"] == stored and scene_fingerprint() == before


def test_an_added_point_regrades(grading_scene):
    """An edge split at an added point re-grades like any edit."""
    s = grading_scene
    cache, solve = addon().cache.CACHE, addon().solve
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    first = solve.last_result("adjust")
    pattern = _read(PENCIL)
    pn = next(p for p in pattern.panels if any(e.kind == "quadratic" for e in p.edges))
    quad = next(e for e in pn.edges if e.kind == "quadratic")
    _add_point(addon().scene_io.panel_objects(s.pattern)[pn.name], quad.id)
    assert bpy.ops.seamfit.apply_edits() == {"FINISHED"}
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    second = solve.last_result("adjust")
    from seamfit.pattern.sewpat import pattern_from_dict
    import json
    base = pattern_from_dict(json.loads(second.base_pattern_json)).panel(pn.name)
    new_id = max(x.id for x in pn.edges) + 1
    first_half, second_half = (next(e for e in base.edges if e.id == i) for i in (quad.id, new_id))
    assert first_half.kind == "quadratic" and first_half.end == second_half.start
    assert second.pattern_json != first.pattern_json
    assert cache.misses["grade"] == 2
