# SPDX-License-Identifier: GPL-3.0-or-later
"""Disabling removes everything the extension registered; enabling again works.
(Named to run last: the session's other tests need the extension enabled.)"""
import bpy
import addon_utils

from helpers import MODULE, PENCIL


def test_disable_and_enable_again(scene):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    objects = sorted(o.name for o in bpy.data.objects)
    bpy.ops.preferences.addon_disable(module=MODULE)
    assert MODULE not in bpy.context.preferences.addons
    assert not hasattr(bpy.types, "SEAMFIT_PT_patterns")
    assert not hasattr(bpy.types.Scene, "seamfit")
    assert not hasattr(bpy.types.Collection, "seamfit")
    import bpy.types as t
    assert all(not name.startswith("SEAMFIT_") for name in dir(t))
    # The user's data stays.
    assert sorted(o.name for o in bpy.data.objects) == objects

    bpy.ops.preferences.addon_enable(module=MODULE)
    assert MODULE in bpy.context.preferences.addons
    assert addon_utils.check(MODULE)[1]
    # The stored pattern is picked up again by the re-registered properties.
    coll = next(c for c in bpy.data.collections if "seamfit_pattern" in c)
    assert len(coll.seamfit.panels) == 4
