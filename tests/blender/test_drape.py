# SPDX-License-Identifier: GPL-3.0-or-later
"""Drape: the base garment on the base body, through the operator, the worker thread and
the cache; compared with `seamfit drape` on the same inputs."""
import os
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest

from helpers import (BODY_BASE, PENCIL, addon, extension_site_packages, object_fingerprint, scene_fingerprint,
                     scene_for, undo, undo_push)

EDGE_CM, SDF_M = 4.0, 0.005     # coarse, so a drape takes seconds


@pytest.fixture()
def setup(scene):
    return scene_for(scene, EDGE_CM, 1000 * SDF_M)


def _garment(coll):
    (obj,) = [o for o in coll.objects if o.type == "MESH" and "stretch_ratio" in o.data.attributes]
    return obj


def _positions(obj):
    co = np.empty(3 * len(obj.data.vertices))
    obj.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


@pytest.fixture(scope="module")
def cli_drape(tmp_path_factory):
    """`seamfit drape` run by the seamfit the extension installed."""
    out = tmp_path_factory.mktemp("cli-drape")
    env = {"PYTHONPATH": str(extension_site_packages()), "PATH": "/usr/bin:/bin",
           "SEAMFIT_CACHE_DIR": os.environ["SEAMFIT_CACHE_DIR"]}
    proc = subprocess.run([sys.executable, "-m", "seamfit", "drape", str(PENCIL), str(BODY_BASE), "--out", str(out),
                           "--edge-length", str(EDGE_CM), "--sdf-spacing", str(SDF_M), "--no-picture", "-q"], env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    from seamfit.mesh import read_obj_positions
    return read_obj_positions(out / "garment.obj")


def test_drape_matches_the_command_line(setup, cli_drape):
    base_before = sorted(object_fingerprint(o) for o in setup.pattern.objects)
    body_before = object_fingerprint(setup.base_body)
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    coll = bpy.data.collections[f"{setup.pattern.name} on women_size06"]
    assert coll.seamfit.role == "drape"
    x = _positions(_garment(coll))
    assert x.shape == cli_drape.shape
    # Same inputs, same solver: the same garment (up to float32 storage in Blender).
    assert np.abs(x - cli_drape).max() < 1e-5
    me = _garment(coll).data
    ratio = np.empty(len(me.vertices), dtype=np.float32)
    me.attributes["stretch_ratio"].data.foreach_get("value", ratio)
    assert 0.9 < float(np.median(ratio)) < 1.1
    assert "stretch_color" in me.color_attributes and me.color_attributes.active_color.name == "stretch_color"
    fit = coll.seamfit.fit
    # A pencil skirt fits the hips closely (a few cm of ease at most) and has no bust.
    assert fit.valid and fit.has_hip and -1.0 < fit.hip < 8.0
    assert not fit.has_bust
    assert sorted(object_fingerprint(o) for o in setup.pattern.objects) == base_before
    assert object_fingerprint(setup.base_body) == body_before


def test_same_inputs_reuse_the_cached_drape(setup):
    cache = addon().cache.CACHE
    bpy.ops.seamfit.drape()
    t0 = time.perf_counter()
    bpy.ops.seamfit.drape()
    again = time.perf_counter() - t0
    assert cache.hits["drape"] == 1 and cache.misses["drape"] == 1
    assert again < 1.0
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "drape"]    # the result, kept as it was
    x = _positions(_garment(coll))
    # A different resolution is a different garment, in place of the first.
    setup.edge_length_cm = 5.0
    bpy.ops.seamfit.drape()
    assert cache.misses["drape"] == 2 and cache.hits["sdf"] >= 1
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "drape"]
    assert coll.name == f"{setup.pattern.name} on women_size06"
    assert len(_positions(_garment(coll))) != len(x)


def test_drape_in_a_worker_thread(setup):
    solve = addon().solve
    runner = solve.Runner(solve.drape_task(bpy.context)).start()
    assert runner.job.wait(120)
    assert len(runner.job.history) > 0            # live residuals came in
    status, message = runner.finish(bpy.context)
    assert status == "FINISHED", message
    assert any(c.seamfit.role == "drape" for c in bpy.data.collections)


def test_cancel_leaves_the_scene_as_it_was(setup):
    solve = addon().solve
    before = scene_fingerprint()
    runner = solve.Runner(solve.drape_task(bpy.context)).start()
    while not runner.job.history and not runner.job.done:
        time.sleep(0.01)
    runner.cancel()
    assert runner.job.wait(60)
    status, message = runner.finish(bpy.context)
    assert status == "CANCELLED" and "unchanged" in message
    assert scene_fingerprint() == before
    assert addon().cache.CACHE.counts()["drape"] == 0     # nothing half-done is kept


def test_undo_removes_the_drape(setup):
    undo_push("before drape")
    before = scene_fingerprint()
    bpy.ops.seamfit.drape()
    undo_push("Drape")
    assert scene_fingerprint() != before
    undo()
    assert scene_fingerprint() == before


def test_failures_change_nothing(setup):
    before = scene_fingerprint()
    setup.device = "CUDA"
    with pytest.raises(RuntimeError, match="cuda|CUDA"):
        bpy.ops.seamfit.drape()
    setup.device = "AUTO"
    bpy.ops.mesh.primitive_plane_add(size=0.5)
    plane = bpy.context.active_object
    before = scene_fingerprint()
    setup.base_body = plane
    with pytest.raises(RuntimeError, match="Plane"):
        bpy.ops.seamfit.drape()
    assert scene_fingerprint() == before
