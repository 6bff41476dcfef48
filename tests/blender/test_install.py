# SPDX-License-Identifier: GPL-3.0-or-later
"""The built zip installs like any extension and brings its own seamfit."""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import bpy
import pytest

from helpers import MODULE, addon


def _extension_site_packages() -> Path:
    return Path(bpy.utils.user_resource("EXTENSIONS", path=".local"))


def test_zip_installs_and_enables(installed):
    assert MODULE in bpy.context.preferences.addons
    pkg = addon()
    assert Path(pkg.__file__).parent.name == "seamfit"
    for op in ("import_pattern", "export_pattern", "drape", "adjust", "check_bodies", "cancel", "load_size_chart",
               "body_from_measurements", "register_target"):
        assert hasattr(bpy.ops.seamfit, op), op
        assert getattr(bpy.ops.seamfit, op).get_rna_type() is not None
    for cls in ("SEAMFIT_PT_patterns", "SEAMFIT_PT_bodies", "SEAMFIT_PT_measure", "SEAMFIT_PT_costs", "SEAMFIT_PT_run"):
        assert hasattr(bpy.types, cls), cls
    assert hasattr(bpy.types.Scene, "seamfit")


def test_bundled_wheels_are_the_ones_used(installed):
    """seamfit, scipy and gmsh come from the wheels inside the zip (conftest hides any
    other copy), and gmsh's native library loads."""
    import gmsh
    import scipy.sparse.linalg
    import seamfit
    import seamfit._native
    site = _extension_site_packages().resolve()
    for mod in (seamfit, scipy, gmsh):
        assert site in Path(mod.__file__).resolve().parents, (mod.__name__, mod.__file__)
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        assert gmsh.isInitialized()
    finally:
        gmsh.finalize()
    core = seamfit._native.core()
    assert hasattr(core, "built_with_cuda")
    assert scipy.sparse.linalg.spsolve is not None


def test_user_scene_props_defaults(scene):
    s = scene.seamfit
    assert s.pattern is None and s.base_body is None and s.target_body is None
    assert s.edge_length_cm == 3.0
    assert s.device == "AUTO"
    assert s.strength_preset == "dress"
    assert (s.strength_fix, s.strength_cur, s.strength_dis, s.strength_smo, s.strength_str,
            s.strength_pos) == pytest.approx((100.0, 1e6, 1.0, 0.05, 1.0, 100.0), rel=1e-6)
    assert s.strength_seam == pytest.approx(1e6)


def test_operators_that_change_the_scene_are_undoable(installed):
    for cls in ("SEAMFIT_OT_import_pattern", "SEAMFIT_OT_build_mesh", "SEAMFIT_OT_drape", "SEAMFIT_OT_adjust",
                "SEAMFIT_OT_check_bodies", "SEAMFIT_OT_apply_edits", "SEAMFIT_OT_body_from_measurements",
                "SEAMFIT_OT_register_target", "SEAMFIT_OT_load_size_chart"):
        assert "UNDO" in getattr(bpy.types, cls).bl_options, cls
    # Export writes files only; drape and adjust have no redo panel (it would recompute).
    assert "UNDO" not in bpy.types.SEAMFIT_OT_export_pattern.bl_options
    assert "REGISTER" not in bpy.types.SEAMFIT_OT_adjust.bl_options


def test_lean_portable_wheels(installed, addon_zip):
    """seamfit is a manylinux wheel carrying its own OpenMP runtime; scipy carries only the
    subpackages seamfit uses, without test suites."""
    import zipfile
    names = zipfile.ZipFile(addon_zip).namelist()
    # One seamfit wheel per Python the zip was built for (cp311; build_addon.sh --cp313 adds
    # cp313's): the one of this Python's tag is installed.
    wheels = [n for n in names if n.startswith("wheels/seamfit-")]
    assert len({n.split("-")[2] for n in wheels}) == len(wheels), wheels
    tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
    (seamfit_wheel,) = [n for n in wheels if f"-{tag}-{tag}-" in n]
    assert "-manylinux_" in seamfit_wheel
    site = (_extension_site_packages() / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}"
            / "site-packages")
    assert list(site.glob(f"seamfit/_core.cpython-{tag[2:]}-*.so")), "seamfit's wheel for this Python"
    gomp = list((site / "seamfit.libs").glob("libgomp-*.so*"))
    assert len(gomp) == 1
    import seamfit._native
    seamfit._native.core()
    maps = Path("/proc/self/maps").read_text()
    assert str(gomp[0].resolve()) in maps or gomp[0].name in maps       # the bundled one is loaded
    scipy_dir = site / "scipy"
    assert (scipy_dir / "sparse").is_dir() and (scipy_dir / "optimize").is_dir()
    for unused in ("stats", "io", "signal", "interpolate", "ndimage"):
        assert not (scipy_dir / unused).exists(), unused
    assert not list(scipy_dir.glob("*/tests"))


def test_a_python_with_the_extension_exits_cleanly(addon_zip, tmp_path):
    """A Python with bpy that enabled the extension ends with its own exit status, and frees
    bpy on the way (Blender 4.2 runs its exit only then: else it frees its Python panels after
    Python has ended, SIGSEGV). Python's -v log says when bpy is freed."""
    from helpers import REPO
    script = tmp_path / "enable_and_exit.py"
    script.write_text(
        "import sys\nimport bpy\n"
        "bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)\n"
        f"r = bpy.ops.extensions.package_install_files(filepath={str(addon_zip)!r}, repo='user_default', "
        "enable_on_install=True)\n"
        "assert r == {'FINISHED'} and 'bl_ext.user_default.seamfit' in bpy.context.preferences.addons\n"
        "sys.exit(3)\n")
    # Its own user folder (the installed extension, about 300 MB), removed afterwards.
    with tempfile.TemporaryDirectory(prefix="seamfit-exit-user-") as user:
        env = dict(os.environ, BLENDER_USER_RESOURCES=user)
        proc = subprocess.run([sys.executable, "-v", str(REPO / "tests" / "blender" / "run_isolated.py"),
                               str(script)], env=env, capture_output=True, text=True)
    assert proc.returncode == 3, proc.stderr[-3000:]
    assert "# destroy bpy\n" in proc.stderr
