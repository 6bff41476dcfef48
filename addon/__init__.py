# SPDX-License-Identifier: GPL-3.0-or-later
"""seamfit for Blender: import sewing patterns, drape them on bodies and grade them to new
bodies. Blender glue only; every computation is done by the ``seamfit`` package, which the
extension bundles as a wheel."""

from . import bodies, operators, overlay, prefs, props, size_run, solve, ui
from .cache import CACHE

_MODULES = (prefs, props, operators, solve, bodies, ui, size_run, overlay)


def register():
    for mod in _MODULES:
        mod.register()


def unregister():
    for mod in reversed(_MODULES):
        mod.unregister()
    CACHE.clear()
