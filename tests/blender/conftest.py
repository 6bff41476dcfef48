# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests of the Blender extension, run inside a Python that has the bpy module.

tests/addon/test_addon_blender.py builds the extension zip and runs this folder once per bpy
version found (SEAMFIT_BPY_SUITE=1 marks that run; a plain `pytest tests` skips
collecting it, since its own Python has no bpy). To run it by hand:

    SEAMFIT_BPY_SUITE=1 SEAMFIT_ADDON_ZIP=dist/seamfit-0.1.0.zip \
        .venv-blender-5.0.1/bin/python -m pytest tests/blender
"""
from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sample_files"

if os.environ.get("SEAMFIT_BPY_SUITE") != "1":
    collect_ignore_glob = ["*.py"]
else:
    # Before bpy is imported: keep Blender's user folders (preferences, extensions) out of ~.
    USER_RESOURCES = Path(tempfile.mkdtemp(prefix="seamfit-blender-user-"))
    # The installed extension and its caches take about 350 MB: removed when the run ends.
    atexit.register(shutil.rmtree, USER_RESOURCES, ignore_errors=True)
    os.environ["BLENDER_USER_RESOURCES"] = str(USER_RESOURCES)
    # seamfit's own disk caches (distance fields, base drapes) start empty for every run.
    os.environ["SEAMFIT_CACHE_DIR"] = str(USER_RESOURCES / "seamfit-cache")

    sys.path.insert(0, str(Path(__file__).parent))
    import isolation  # noqa: E402

    isolation.install(str(USER_RESOURCES))

    import bpy  # noqa: E402

    MODULE = "bl_ext.user_default.seamfit"

    @pytest.fixture(scope="session")
    def addon_zip() -> Path:
        zip_path = os.environ.get("SEAMFIT_ADDON_ZIP")
        if not zip_path or not Path(zip_path).is_file():
            pytest.fail("SEAMFIT_ADDON_ZIP must name the built extension (scripts/build_addon.sh)")
        return Path(zip_path)

    @pytest.fixture(scope="session")
    def installed(addon_zip):
        """Install the zip the way a user does (Get Extensions > Install from Disk)."""
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        result = bpy.ops.extensions.package_install_files(
            filepath=str(addon_zip), repo="user_default", enable_on_install=True)
        assert result == {"FINISHED"}
        assert MODULE in bpy.context.preferences.addons
        return MODULE

    @pytest.fixture()
    def scene(installed):
        """An empty scene with factory settings, the extension enabled."""
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        if MODULE not in bpy.context.preferences.addons:
            bpy.ops.preferences.addon_enable(module=MODULE)
        from bl_ext.user_default.seamfit import cache
        cache.CACHE.clear()
        return bpy.context.scene

    @pytest.fixture()
    def grading_scene(scene):
        """The sample skirt imported, base and target bodies set, coarse grading settings
        (those of helpers.GRADE_ARGS): the scene settings, ready for Adjust."""
        from helpers import grading_scene_for
        return grading_scene_for(scene)

    @pytest.fixture()
    def tmp_out(tmp_path) -> Path:
        return tmp_path

    def _cli_grade(tmp_path_factory, *extra: str):
        """`seamfit grade` on the sample skirt (the settings of helpers.GRADE_ARGS plus
        ``extra``), run by the seamfit the extension installed; (pattern, report, output folder)."""
        import json
        import subprocess
        from helpers import BODY_BASE, BODY_TARGET, GRADE_ARGS, PENCIL, extension_site_packages
        from seamfit.pattern import load_pattern
        out = tmp_path_factory.mktemp("cli-grade")
        env = {"PYTHONPATH": str(extension_site_packages()), "PATH": "/usr/bin:/bin",
               "SEAMFIT_CACHE_DIR": os.environ["SEAMFIT_CACHE_DIR"]}
        # The numeric libraries' own settings stay as the batch script's Blender has them:
        # OpenBLAS picks its kernels by CPU unless OPENBLAS_CORETYPE names one, and kernels
        # that round differently part the two gradings by nanometres.
        env.update({k: v for k, v in os.environ.items() if k.startswith(("OPENBLAS_", "OMP_", "MKL_"))})
        proc = subprocess.run([sys.executable, "-m", "seamfit", "grade", str(PENCIL), "--base-body", str(BODY_BASE),
                               "--target-body", str(BODY_TARGET), "--out", str(out), "--no-picture", "-q",
                               *GRADE_ARGS, *extra], env=env, capture_output=True, text=True)
        assert proc.returncode in (0, 1), proc.stderr
        return load_pattern(out / "pattern.json"), json.loads((out / "report.json").read_text()), out

    @pytest.fixture(scope="session")
    def cli_grade(tmp_path_factory, installed):
        """The command line's grading with the default method."""
        return _cli_grade(tmp_path_factory)

    @pytest.fixture(scope="session")
    def cli_grade_two_phase(tmp_path_factory, installed):
        """The command line's grading with the two-phase baseline."""
        return _cli_grade(tmp_path_factory, "--method", "two-phase")
