# SPDX-License-Identifier: GPL-3.0-or-later
"""Build the Blender extension and run its bpy test suite (tests/blender) in each Python
that has the bpy module: Blender can be imported once per process and each Blender
version has its own bpy, so every suite runs in a subprocess.

SEAMFIT_BPY_PYTHONS: os.pathsep-separated interpreters with bpy installed (default: every
.venv-blender*/bin/python of the repository, made by scripts/setup.sh).
SEAMFIT_ADDON_ZIP: an already built extension zip (default: built here into build/).
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from common import REPO



def _bpy_pythons() -> list[str]:
    given = os.environ.get("SEAMFIT_BPY_PYTHONS")
    if given:
        return [p for p in given.split(os.pathsep) if p]
    found = sorted(str(p) for p in REPO.glob(".venv-blender*/bin/python"))
    return found or [str(REPO / ".venv-blender" / "bin" / "python")]


@pytest.fixture(scope="module")
def addon_zip(tmp_path_factory) -> Path:
    given = os.environ.get("SEAMFIT_ADDON_ZIP")
    if given:
        return Path(given)
    bpy_python = _bpy_pythons()[0]
    out = tmp_path_factory.mktemp("addon-dist")
    env = dict(os.environ, PYTHON=sys.executable, BPY_PYTHON=bpy_python, OUT=str(out))
    proc = subprocess.run(["bash", str(REPO / "scripts" / "build_addon.sh")], cwd=REPO, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"build_addon.sh failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    (zip_path,) = out.glob("seamfit-*.zip")
    return zip_path


@pytest.mark.parametrize("bpy_python", _bpy_pythons())
def test_blender_suite(bpy_python, addon_zip):
    assert Path(bpy_python).exists(), (
        f"no Python with bpy at {bpy_python}: run scripts/setup.sh or set SEAMFIT_BPY_PYTHONS")
    env = dict(os.environ, SEAMFIT_BPY_SUITE="1", SEAMFIT_ADDON_ZIP=str(addon_zip))
    proc = subprocess.run([bpy_python, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           str(REPO / "tests" / "blender")],
                          cwd=REPO, env=env, capture_output=True, text=True)
    print(proc.stdout[-5000:])
    assert proc.returncode == 0, f"bpy suite failed under {bpy_python}:\n{proc.stdout[-8000:]}\n{proc.stderr[-3000:]}"
