# SPDX-License-Identifier: GPL-3.0-or-later
"""Make seamfit, scipy and gmsh importable only from the seamfit extension's own wheels
(under BLENDER_USER_RESOURCES), as in a Blender that never had them, even when this
Python's site-packages has them. No bpy here: it must be installed before bpy is imported."""
from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys


class OnlyFromExtension(importlib.abc.MetaPathFinder):
    NAMES = {"seamfit", "scipy", "gmsh"}

    def __init__(self, root: str):
        self.root = os.path.realpath(root)

    def find_spec(self, name, path, target=None):
        if path is not None or name not in self.NAMES:
            return None
        allowed = [p for p in sys.path if os.path.realpath(p or ".").startswith(self.root)]
        spec = importlib.machinery.PathFinder.find_spec(name, allowed)
        if spec is None:
            raise ModuleNotFoundError(f"{name} is not installed by the seamfit extension", name=name)
        return spec


def install(root: str) -> None:
    if os.environ.get("SEAMFIT_BPY_ISOLATE", "1") == "1":
        sys.meta_path.insert(0, OnlyFromExtension(root))
