# SPDX-License-Identifier: GPL-3.0-or-later
"""Run a script (argv[1], with the rest as its arguments) the way a user's Python with bpy
would: seamfit, scipy and gmsh only from the extension that script installs (under
$SEAMFIT_ISOLATION_ROOT, or else $BLENDER_USER_RESOURCES)."""
import os
import runpy
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import isolation  # noqa: E402

isolation.install(os.environ.get("SEAMFIT_ISOLATION_ROOT") or os.environ["BLENDER_USER_RESOURCES"])
script = sys.argv[1]
sys.argv = sys.argv[1:]
runpy.run_path(script, run_name="__main__")
