# SPDX-License-Identifier: GPL-3.0-or-later
"""The extension's preferences: where seamfit's disk cache lives and how large it may grow."""
from __future__ import annotations

import bpy
from bpy.props import FloatProperty

from . import cache


def _limit_changed(self, context):
    cache.set_disk_limit(self.cache_limit_mb)


class SEAMFIT_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    cache_limit_mb: FloatProperty(
        name="Disk cache limit (MB)", default=cache.DEFAULT_LIMIT_MB, min=0.0, soft_max=65536.0, precision=0,
        update=_limit_changed,
        description="Most disk space for cached body distance fields and base drapes; the least recently used "
                    "go first (0 keeps nothing)")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "cache_limit_mb")
        n, size = cache.disk_usage()
        layout.label(text=f"{cache.disk_folder()}: {n} entries, {size / 2**20:.0f} MB", icon="FILE_FOLDER")
        layout.operator("seamfit.clear_cache", icon="TRASH")


def preferences():
    addon = bpy.context.preferences.addons.get(__package__)
    return addon.preferences if addon is not None else None


def register():
    bpy.utils.register_class(SEAMFIT_AP_preferences)
    # Blender's user folder of the extension (under its user resources), not the home folder.
    cache.use_disk_folder(bpy.utils.extension_path_user(__package__, path="cache", create=True))
    prefs = preferences()
    cache.set_disk_limit(prefs.cache_limit_mb if prefs is not None else cache.DEFAULT_LIMIT_MB)


def unregister():
    cache.forget_environment()
    bpy.utils.unregister_class(SEAMFIT_AP_preferences)
