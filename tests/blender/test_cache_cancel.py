# SPDX-License-Identifier: GPL-3.0-or-later
"""seamfit's disk cache as the extension keeps it (Blender's user folder, a size limit,
Clear Cache), and Esc while a body field is being built."""
import os
import threading
from pathlib import Path

import bpy
import pytest

from helpers import MODULE, addon, scene_fingerprint, scene_for


@pytest.fixture()
def setup(scene):
    return scene_for(scene, 4.0, 5.0)


def _disk():
    from seamfit import cache as disk
    return disk.cache_entries()


def test_disk_cache_lives_in_blenders_user_folder(installed):
    given = os.environ.pop("SEAMFIT_CACHE_DIR")
    try:
        bpy.ops.preferences.addon_disable(module=MODULE)
        bpy.ops.preferences.addon_enable(module=MODULE)
        folder = Path(addon().cache.disk_folder())
        assert folder.is_relative_to(os.environ["BLENDER_USER_RESOURCES"]) and folder.name == "cache"
        assert os.environ["SEAMFIT_CACHE_DIR"] == str(folder)
        bpy.ops.preferences.addon_disable(module=MODULE)
        assert "SEAMFIT_CACHE_DIR" not in os.environ         # nothing of ours left behind
    finally:
        os.environ["SEAMFIT_CACHE_DIR"] = given
        if MODULE not in bpy.context.preferences.addons:
            bpy.ops.preferences.addon_enable(module=MODULE)
    # A folder the user chose is kept.
    assert addon().cache.disk_folder() == given


def test_clear_cache_clears_the_disk_and_the_limit_holds(setup):
    prefs = bpy.context.preferences.addons[MODULE].preferences
    bpy.ops.seamfit.clear_cache()       # what earlier tests left
    assert _disk() == []
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    setup.sdf_spacing_mm = 6.0
    assert bpy.ops.seamfit.drape() == {"FINISHED"}
    entries = _disk()
    assert len(entries) == 2            # the body's distance fields at 5 and 6 mm
    total = sum(size for _, size, _ in entries)
    # A limit under what is stored: the least recently used entries go at once.
    prefs.cache_limit_mb = 0.9 * total / 2**20
    left = _disk()
    assert 0 < len(left) < len(entries) and sum(size for _, size, _ in left) <= 0.9 * total
    prefs.cache_limit_mb = 2048
    cache = addon().cache.CACHE
    assert cache.counts()["sdf"] == 2
    assert bpy.ops.seamfit.clear_cache() == {"FINISHED"}
    assert _disk() == [] and sum(cache.counts().values()) == 0


def test_esc_while_the_body_field_is_built(setup):
    """Cancel answers at once in the stage that cannot stop part way (seamfit builds a body
    field in one call): the run ends, the scene is as it was, and the field's build goes on
    in its thread until it returns, then nothing is applied."""
    solve = addon().solve
    setup.sdf_spacing_mm = 3.3          # a field not built before in this run
    before = scene_fingerprint()
    seen = threading.Event()
    runner = solve.Runner(solve.drape_task(bpy.context))
    job = runner.job
    update = job.update

    def watch(stage=None, **kw):
        update(stage=stage, **kw)
        if stage == "body fields":
            seen.set()
    job.update = watch
    runner.start()
    assert seen.wait(60)
    assert not runner.answered()
    runner.cancel()
    assert runner.answered()            # what the modal operator checks on Esc: it ends now
    status, message = runner.finish(bpy.context)
    assert status == "CANCELLED" and "unchanged" in message
    assert not job.done                 # the field was still being built: not waited for
    assert addon().jobs.active() is None    # a new run may start
    assert scene_fingerprint() == before
    assert job.wait(120)
    assert scene_fingerprint() == before
    assert addon().cache.CACHE.counts()["drape"] == 0
