# SPDX-License-Identifier: GPL-3.0-or-later
"""Adjust: the whole grading through the operator, compared with `seamfit grade` on the
same inputs; cache reuse, undo, cancel, export of the result."""
import time

import bpy
import numpy as np
import pytest

from helpers import PENCIL, addon, object_fingerprint, scene_fingerprint, undo, undo_push


@pytest.fixture()
def setup(grading_scene):
    return grading_scene


def _graded_collections():
    return [c for c in bpy.data.collections if c.seamfit.role == "graded"]


def _assert_same_pattern(a, b, tol_cm):
    assert [p.name for p in a.panels] == [p.name for p in b.panels]
    for pa, pb in zip(a.panels, b.panels):
        assert pa.outline_cm.shape == pb.outline_cm.shape
        assert np.abs(pa.outline_cm - pb.outline_cm).max() <= tol_cm, pa.name


def test_adjust_matches_the_command_line(setup, cli_grade):
    from seamfit.pattern import load_pattern
    cli_pattern, cli_report, _ = cli_grade
    base = setup.pattern
    base_before = sorted(object_fingerprint(o) for o in base.objects)
    bodies_before = [object_fingerprint(o) for o in (setup.base_body, setup.target_body)]
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    (coll,) = _graded_collections()
    assert coll.name == f"women_size10 {base.name}"
    assert coll.seamfit.body == "women_size10" and coll["seamfit_base"] == base.name
    # New curves, one per panel, read back from the scene, are the command line's pattern.
    ours = addon().scene_io.pattern_from_collection(coll)
    _assert_same_pattern(ours, cli_pattern, tol_cm=1e-3)
    assert ours.body_id == cli_pattern.body_id == "women_size10"
    assert coll.seamfit.objective == pytest.approx(cli_report["objective_final"], rel=1e-6)
    assert coll.seamfit.iterations == cli_report["outer_iterations"]
    # The pattern really changed, and the base did not.
    original = load_pattern(PENCIL)
    assert max(np.abs(p.outline_cm - q.outline_cm).max() for p, q in zip(ours.panels, original.panels)) > 0.1
    assert sorted(object_fingerprint(o) for o in base.objects) == base_before
    assert [object_fingerprint(o) for o in (setup.base_body, setup.target_body)] == bodies_before
    # The garment on the target, coloured by stretch, and the fit.
    (garment,) = [o for o in coll.objects if o.type == "MESH" and "stretch_ratio" in o.data.attributes]
    assert len(garment.data.polygons) > 0
    fit = coll.seamfit.fit
    want = cli_report["ease_cm"]["result"]
    assert fit.valid and fit.has_hip and fit.hip == pytest.approx(want["hip"], abs=0.02)


def test_unchanged_inputs_are_instant_and_strengths_reuse_the_base(setup):
    cache = addon().cache.CACHE
    solve = addon().solve
    bpy.ops.seamfit.adjust()
    before = scene_fingerprint()
    t0 = time.perf_counter()
    bpy.ops.seamfit.adjust()
    assert time.perf_counter() - t0 < 2.0
    assert cache.hits["grade"] == 1
    assert scene_fingerprint() == before        # the cache hit added nothing
    (a,) = _graded_collections()
    # Only a strength changed: a new grading, on the cached base drape, replacing the first.
    setup.strength_smo = 0.5
    bpy.ops.seamfit.adjust()
    assert cache.misses["grade"] == 2
    assert solve.last_result().report["base_drape"]["cached"] is True
    (b,) = _graded_collections()
    assert b.name == f"women_size10 {setup.pattern.name}"


def test_undo_restores_the_replaced_result(setup):
    smo = setup.strength_smo
    bpy.ops.seamfit.adjust()        # fills the cache, so the run under test is instant
    setup.strength_smo = 0.5
    bpy.ops.seamfit.adjust()        # replaces the first result
    undo_push("before adjust")
    before = scene_fingerprint()
    setup.strength_smo = smo
    bpy.ops.seamfit.adjust()        # the first result again, in place of the second
    undo_push("Adjust Pattern")
    assert scene_fingerprint() != before
    undo()
    assert scene_fingerprint() == before


def test_cancel_during_optimization_leaves_the_scene(setup):
    solve = addon().solve
    before = scene_fingerprint()
    runner = solve.Runner(solve.adjust_task(bpy.context)).start()
    while runner.job.snapshot()["stage"] != "optimizing" and not runner.job.done:
        time.sleep(0.02)
    runner.cancel()
    assert runner.job.wait(120)
    status, message = runner.finish(bpy.context)
    assert status == "CANCELLED", message
    assert scene_fingerprint() == before
    assert addon().cache.CACHE.counts()["grade"] == 0


def test_export_the_graded_pattern(setup, cli_grade, tmp_out):
    import xml.etree.ElementTree as ET
    from seamfit.pattern import load_pattern
    bpy.ops.seamfit.adjust()
    (coll,) = _graded_collections()
    out = tmp_out / "graded.json"
    assert bpy.ops.seamfit.export_pattern(filepath=str(out), collection=coll.name, format="SEWPAT") == {"FINISHED"}
    _assert_same_pattern(load_pattern(out), cli_grade[0], tol_cm=1e-3)
    svg = tmp_out / "graded.svg"
    bpy.ops.seamfit.export_pattern(filepath=str(svg), collection=coll.name, format="SVG")
    root = ET.parse(svg).getroot()
    labels = [g.get("data-label") for g in root.iter("{http://www.w3.org/2000/svg}g") if g.get("data-label")]
    assert sorted(labels) == sorted([coll.name, setup.pattern.name])     # graded over its base
