# SPDX-License-Identifier: GPL-3.0-or-later
"""A clean scene: a re-run replaces its own result (or, on unchanged inputs, leaves the
scene exactly as it was), one stretch material for every map, and the compare view."""
import bpy
import numpy as np
import pytest

from helpers import addon, datablock_counts, object_fingerprint, scene_fingerprint


_warm: dict = {}


@pytest.fixture()
def grading_scene(grading_scene):
    """The grading scene, with the add-on's cache as the previous test of this file left it:
    these tests are about the scene, and the same gradings recur (seconds each on 2 cores)."""
    cache = addon().cache.CACHE
    for stage, entries in _warm.items():
        cache._stages[stage].update(entries)
    yield grading_scene
    _warm.update({stage: dict(entries) for stage, entries in cache._stages.items()})


def _results(role):
    return [c for c in bpy.data.collections if c.seamfit.role == role]


def _names(coll):
    return sorted(o.name for o in coll.all_objects)


def test_ten_adjust_runs_leave_one_result(grading_scene):
    s = grading_scene
    base_before = sorted(object_fingerprint(o) for o in s.pattern.objects)
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    (first,) = _results("graded")
    # Something of the artist's own in the result's collection survives the replacements.
    mine = bpy.data.objects.new("my reference", None)
    first.objects.link(mine)
    name, objects = first.name, _names(first)
    counts = datablock_counts()
    # Two strengths, alternately: every run is a different result (cached after the first two).
    for k in range(10):
        s.strength_smo = 0.05 if k % 2 else 0.5
        assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    (coll,) = _results("graded")
    assert coll.name == name and _names(coll) == objects      # the same names, no ".001"
    assert mine.name in coll.objects
    assert datablock_counts() == counts
    assert [m.name for m in bpy.data.materials] == ["seamfit stretch"]
    assert sorted(object_fingerprint(o) for o in s.pattern.objects) == base_before


def test_a_cache_hit_changes_nothing(grading_scene):
    bpy.ops.seamfit.adjust()
    bpy.ops.seamfit.drape()
    before = scene_fingerprint()
    counts = datablock_counts()
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    assert scene_fingerprint() == before and datablock_counts() == counts
    # Drape and grading share the one stretch material.
    (mat,) = bpy.data.materials
    assert mat.users == 2 * (1 + 1 + 3)      # two garments, their legends' bars and three labels each


def test_keep_previous_results(grading_scene):
    s = grading_scene
    bpy.ops.seamfit.adjust()
    s.keep_results = True
    s.strength_smo = 0.5
    bpy.ops.seamfit.adjust()
    kept, newest = _results("graded")
    assert kept.name == f"women_size10 {s.pattern.name}" and newest.name != kept.name
    # Without keep, the next run replaces only the newest; the kept one stays as it was.
    s.keep_results = False
    kept_before = sorted(object_fingerprint(o) for o in kept.all_objects)
    s.strength_smo = 0.05
    bpy.ops.seamfit.adjust()
    assert len(_results("graded")) == 2
    assert sorted(object_fingerprint(o) for o in kept.all_objects) == kept_before


def test_a_result_missing_objects_is_rebuilt(grading_scene):
    bpy.ops.seamfit.adjust()
    (coll,) = _results("graded")
    objects = _names(coll)
    garment = next(o for o in coll.objects if o.type == "MESH" and "stretch_ratio" in o.data.attributes)
    bpy.data.objects.remove(garment)
    bpy.ops.seamfit.adjust()        # same inputs, but the result is not whole any more
    (coll,) = _results("graded")
    assert _names(coll) == objects


def _curve_world(coll, obj):
    """The panel's outline as the scene holds it (read back from its curve), in world metres."""
    pn = addon().scene_io.pattern_from_collection(coll).panel(obj["seamfit_panel"])
    return pn.placement.to_world(pn.outline_cm)


def test_compare_lays_base_and_graded_out_flat(grading_scene):
    s = grading_scene
    bpy.ops.seamfit.adjust()
    (graded,) = _results("graded")
    assert bpy.ops.seamfit.compare(collection=graded.name, layout="SIDE_BY_SIDE") == {"FINISHED"}
    (view,) = _results("compare")[:1]
    base_copy, graded_copy = sorted(view.children, key=lambda c: c.name)
    assert "base" in base_copy.name and "graded" in graded_copy.name
    body_right = max(float((np.array(o.bound_box) @ np.array(o.matrix_world)[:3, :3].T
                            + np.array(o.matrix_world)[:3, 3])[:, 0].max()) for o in (s.base_body, s.target_body))
    panels = {}
    for copy in (base_copy, graded_copy):
        for name, obj in addon().scene_io.panel_objects(copy).items():
            w = _curve_world(copy, obj)
            assert np.abs(w[:, 2]).max() <= 0.0011          # flat on the floor
            assert w[:, 0].min() > body_right                # beside the bodies, not on them
            panels.setdefault(name, []).append(w)
    # Outlines as the scene holds them: the graded copy's shape is the graded pattern's.
    ours = addon().scene_io.pattern_from_collection(graded)
    for pn in ours.panels:
        b, g = panels[pn.name]
        assert np.allclose(np.ptp(g[:, :2], axis=0), 0.01 * np.ptp(pn.outline_cm, axis=0), atol=1e-5)
        assert b[:, 0].max() < g[:, 0].min()                 # side by side: graded right of its base
    # The overlay labels both copies' stitch lengths.
    labels = addon().overlay.overlay_items(bpy.context.scene)["labels"]
    in_view = [t for p, t in labels if p[0] > body_right]
    assert len(in_view) == 2 * len(s.pattern.seamfit.stitches)
    # Again: nothing new. Another layout: replaced, aligned at each panel's top middle.
    before = scene_fingerprint()
    bpy.ops.seamfit.compare(collection=graded.name, layout="SIDE_BY_SIDE")
    assert scene_fingerprint() == before
    counts = datablock_counts()
    bpy.ops.seamfit.compare(collection=graded.name, layout="OVERLAY")
    assert datablock_counts() == counts
    (view,) = _results("compare")[:1]
    base_copy, graded_copy = sorted(view.children, key=lambda c: c.name)
    gp = addon().scene_io.panel_objects(graded_copy)
    for name, obj in addon().scene_io.panel_objects(base_copy).items():
        b, g = _curve_world(base_copy, obj), _curve_world(graded_copy, gp[name])
        top = [np.array([0.5 * (w[:, 0].min() + w[:, 0].max()), w[:, 1].max()]) for w in (b, g)]
        assert np.allclose(top[0], top[1], atol=1e-5)


def test_compare_without_a_grading_is_refused(scene):
    with pytest.raises(RuntimeError, match="no graded pattern"):
        bpy.ops.seamfit.compare()
