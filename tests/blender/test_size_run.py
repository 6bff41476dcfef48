# SPDX-License-Identifier: GPL-3.0-or-later
"""Grade Size Run: a coarse two-size run (a scene object and a body file as targets) in one
job, a collection per size, the run's multi-size DXF and grade rules read back by seamfit."""
import time

import bpy
import numpy as np
import pytest

from helpers import SAMPLES, addon, file_digest, object_fingerprint, scene_fingerprint

APPLE = SAMPLES / "bodies" / "women_apple.obj"


@pytest.fixture()
def run_scene(grading_scene):
    s = grading_scene
    s.iterations, s.exact_every = 2, 2      # a coarse, fast run: two outer iterations a size
    s.target_body.select_set(True)
    s.base_body.select_set(True)        # the base body is never a target
    assert bpy.ops.seamfit.run_target_add() == {"FINISHED"}
    assert bpy.ops.seamfit.run_target_add_file(filepath=str(APPLE)) == {"FINISHED"}
    assert [t.obj.name if t.obj else t.filepath for t in s.run_targets] == ["women_size10", str(APPLE)]
    return s


def _runs():
    return [c for c in bpy.data.collections if c.seamfit.role == "size_run"]


def test_two_size_run_and_its_dxf(run_scene, tmp_path):
    from seamfit.pattern.dxf_sizes import parse_rul, read_dxf_sizes
    s = run_scene
    bodies = [object_fingerprint(o) for o in (s.base_body, s.target_body)]
    apple = file_digest(APPLE)
    t0 = time.perf_counter()
    assert bpy.ops.seamfit.grade_size_run() == {"FINISHED"}
    seconds = time.perf_counter() - t0
    (run,) = _runs()
    sizes = [c for c in run.children if c.seamfit.role == "graded"]
    assert sorted(c.seamfit.body for c in sizes) == ["women_apple", "women_size10"]
    base = addon().scene_io.pattern_from_collection(s.pattern)
    for c in sizes:
        assert c["seamfit_base"] == s.pattern.name
        graded = addon().scene_io.pattern_from_collection(c)
        assert [p.name for p in graded.panels] == [p.name for p in base.panels]
        moved = max(np.abs(g.outline_cm - b.outline_cm).max() for g, b in zip(graded.panels, base.panels))
        assert moved > 0.1, c.name      # graded: the outlines moved (cm)
    assert [object_fingerprint(o) for o in (s.base_body, s.target_body)] == bodies and file_digest(APPLE) == apple
    print(f"two-size run: {seconds:.1f} s")

    # Run again on the same inputs: the result stays as it is, nothing is computed.
    before = scene_fingerprint()
    t0 = time.perf_counter()
    assert bpy.ops.seamfit.grade_size_run() == {"FINISHED"}
    assert scene_fingerprint() == before and time.perf_counter() - t0 < 2.0

    out = tmp_path / "pencil_run.dxf"
    assert bpy.ops.seamfit.export_size_run(filepath=str(out), collection=run.name) == {"FINISHED"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pencil_run.dxf", "pencil_run.graded.dxf", "pencil_run.rul"]
    back = read_dxf_sizes(out)
    order = ["women_size06", "women_size10", "women_apple"]      # by girth, the base first
    assert back.labels == order and back.sample_size == "women_size06" and back.flavor == "astm"
    for lab, c in [("women_size06", s.pattern), *((c.seamfit.body, c) for c in sizes)]:
        want = addon().scene_io.pattern_from_collection(c)
        got = back.patterns[lab]
        assert len(got.panels) == len(want.panels)
        for pg, pw in zip(got.panels, want.panels):
            # the nest aligns each size at its top-centre: compare the shapes there (0.1 mm)
            rel = lambda o: o - np.array([0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()])
            assert pg.outline_cm.shape == pw.outline_cm.shape
            assert np.abs(rel(pg.outline_cm) - rel(pw.outline_cm)).max() < 0.01
    rul = parse_rul((tmp_path / "pencil_run.rul").read_text())
    assert rul["sizes"] == order and rul["sample_size"] == "women_size06" and rul["rules"]
    assert all(m.shape == (3, 2) for m in rul["rules"].values())


def test_size_run_cancel_leaves_the_scene(run_scene):
    size_run, solve = addon().size_run, addon().solve
    before = scene_fingerprint()
    runner = solve.Runner(size_run.size_run_task(bpy.context)).start()
    # Esc once the first size's grading is under way.
    while "(1/2): " not in runner.job.snapshot()["stage"] and not runner.job.done:
        time.sleep(0.02)
    assert not runner.job.done
    runner.cancel()
    assert runner.job.wait(120)
    status, message = runner.finish(bpy.context)
    assert status == "CANCELLED", message
    assert scene_fingerprint() == before and not _runs()
