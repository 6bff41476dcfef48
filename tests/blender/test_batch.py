# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/batch_grade.py with the bpy module: the same grading as `seamfit grade`, plus a
.blend with the result."""
import json
import os
import subprocess
import sys
import tempfile

import bpy
import numpy as np

from helpers import BODY_BASE, BODY_TARGET, GRADE_ARGS, PENCIL, REPO


def run_batch(args, cwd=None, tmpdir=None):
    """scripts/batch_grade.py in a fresh Blender with its own user folder, which holds the
    installed extension (about 280 MB) and is removed afterwards. With ``tmpdir`` as the
    system temporary folder, the script makes its own (and must remove them)."""
    with tempfile.TemporaryDirectory(prefix="seamfit-batch-user-") as user:
        env = dict(os.environ, BLENDER_USER_RESOURCES=user)
        if tmpdir is not None:
            del env["BLENDER_USER_RESOURCES"]
            env.update(TMPDIR=str(tmpdir), SEAMFIT_ISOLATION_ROOT=str(tmpdir))
        return subprocess.run([sys.executable, str(REPO / "tests" / "blender" / "run_isolated.py"),
                               str(REPO / "scripts" / "batch_grade.py"), *args],
                              env=env, capture_output=True, text=True, cwd=cwd)


def test_batch_script_writes_the_cli_files_and_a_blend(addon_zip, cli_grade, tmp_out):
    from seamfit.pattern import load_pattern
    cli_pattern, cli_report, cli_out = cli_grade
    out = tmp_out / "batch"
    system_tmp = tmp_out / "tmp"
    system_tmp.mkdir()
    # --seam at the preset's value: accepted like every option of seamfit grade, same result.
    proc = run_batch([str(PENCIL), "--base-body", str(BODY_BASE), "--target-body", str(BODY_TARGET),
                      "--out", str(out), "--addon-zip", str(addon_zip), "--no-picture", "--seam", "1e6",
                      *GRADE_ARGS], cwd=tmp_out, tmpdir=system_tmp)
    assert proc.returncode == 0, proc.stderr[-3000:]   # results written, converged or not
    # The temporary install (the extension and its wheels) is gone with the run.
    assert list(system_tmp.iterdir()) == []
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [p.name for p in cli_out.iterdir()] + ["graded.blend"])
    # The same adjusted pattern and report as the command line.
    ours = load_pattern(out / "pattern.json")
    for a, b in zip(ours.panels, cli_pattern.panels):
        assert a.name == b.name and np.abs(a.outline_cm - b.outline_cm).max() <= 1e-9
    report = json.loads((out / "report.json").read_text())
    assert report.keys() == cli_report.keys()
    assert report["objective_final"] == cli_report["objective_final"]
    assert report["inputs"]["target_body"] == str(BODY_TARGET)
    assert report["strengths"]["seam"] == cli_report["strengths"]["seam"] == 1e6
    # The .blend holds the bodies, the base pattern and the result.
    bpy.ops.wm.open_mainfile(filepath=str(out / "graded.blend"))
    graded = [c for c in bpy.data.collections if c.seamfit.role == "graded"]
    assert [c.name for c in graded] == ["women_size10 gc_pencil_skirt size06"]
    assert {"women_size06", "women_size10"} <= set(bpy.data.objects.keys())
    assert bpy.context.scene.seamfit.pattern.name == "gc_pencil_skirt size06"
    stored = json.loads(graded[0]["seamfit_pattern"])
    assert [p["outline_cm"] for p in stored["panels"]] == \
        [p.outline_cm.tolist() for p in ours.panels]


def test_batch_script_reports_bad_input(addon_zip, tmp_out):
    proc = run_batch([str(tmp_out / "nope.json"), "--base-body", str(BODY_BASE), "--target-body", str(BODY_TARGET),
                      "--out", str(tmp_out / "o"), "--addon-zip", str(addon_zip)])
    assert proc.returncode == 2
    assert "batch_grade: error:" in proc.stderr and "nope.json: no such file" in proc.stderr
    assert not (tmp_out / "o").exists()


def test_batch_script_takes_seamfit_grade_options(addon_zip, tmp_out):
    """Options from seamfit grade's own definition, checked as the command line checks them."""
    proc = run_batch([str(PENCIL), "--base-body", str(BODY_BASE), "--target-body", str(BODY_TARGET),
                      "--out", str(tmp_out / "o"), "--addon-zip", str(addon_zip), "--seam", "-1"])
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert proc.stderr.strip().startswith("batch_grade: error: --seam -1") and len(proc.stderr.strip().splitlines()) == 1
    proc = run_batch([str(PENCIL), "--base-body", str(BODY_BASE), "--target-body", str(BODY_TARGET),
                      "--out", str(tmp_out / "o"), "--addon-zip", str(addon_zip), "--start", "sideways"])
    assert proc.returncode == 2 and "--start" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_out / "o").exists()


def test_batch_script_without_blender_says_how_to_run_it(tmp_out):
    """A Python without bpy (-S: no site-packages) gets one line and the exit status for bad input."""
    proc = subprocess.run([sys.executable, "-S", str(REPO / "scripts" / "batch_grade.py"), str(PENCIL),
                           "--base-body", str(BODY_BASE), "--target-body", str(BODY_TARGET), "--out",
                           str(tmp_out / "o")], capture_output=True, text=True)
    assert proc.returncode == 2         # not 1, which says "stopped at its budget"
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith("batch_grade: error: it needs Blender's Python")
    assert "blender --background --python scripts/batch_grade.py" in line and "No module named" not in line
    assert not (tmp_out / "o").exists()
