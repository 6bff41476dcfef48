#!/usr/bin/env bash
# Build the seamfit Blender extension: dist/seamfit-<version>.zip holds addon/ and, as
# wheels, seamfit itself and the packages it needs that Blender does not ship (scipy,
# gmsh). The zip is made by Blender's own extension builder (bl_pkg, from the bpy module).
#
#   PYTHON       python that builds the seamfit wheel (pybind11, scikit-build-core):  .venv/bin/python
#   BPY_PYTHON   python with the bpy module:                                          .venv-blender/bin/python
#   OUT          where the zip goes:                                                  dist
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

py=${PYTHON:-.venv/bin/python}
bpy_py=${BPY_PYTHON:-.venv-blender/bin/python}
out=${OUT:-dist}
mkdir -p "$out" && out=$(cd "$out" && pwd)
[ -x "$py" ] || { echo "build_addon: no python at $py (run scripts/setup.sh or set PYTHON)" >&2; exit 1; }
[ -x "$bpy_py" ] || { echo "build_addon: no bpy python at $bpy_py (set BPY_PYTHON)" >&2; exit 1; }

# Blender 4.2-5.0 run Python 3.11; scipy 1.15 still supports the numpy 1.24 of Blender 4.2.
pyver=311
platforms=(--platform manylinux_2_28_x86_64 --platform manylinux_2_24_x86_64
           --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64)
scipy_req="scipy>=1.13,<1.16"
gmsh_req="gmsh==4.15.2"

wheels=build/addon-wheels
stage=build/addon-stage/seamfit
mkdir -p "$wheels/seamfit" "$wheels/deps" "$out"
rm -rf build/addon-stage && mkdir -p "$stage/wheels"

# seamfit: scikit-build-core keeps its build folder, so a rebuild only recompiles what changed.
rm -f "$wheels"/seamfit/seamfit-*.whl
"$py" -m pip wheel -q --no-build-isolation --no-deps -w "$wheels/seamfit" .

# Third-party wheels for Blender's Python, downloaded once.
if ! ls "$wheels"/deps/scipy-*.whl >/dev/null 2>&1 || ! ls "$wheels"/deps/gmsh-*.whl >/dev/null 2>&1; then
  "$py" -m pip download -q --no-deps --only-binary :all: --python-version "$pyver" \
      "${platforms[@]}" -d "$wheels/deps" "$scipy_req" "$gmsh_req"
fi

# gmsh's wheel keeps libgmsh in <prefix>/lib, which Blender's wheel installer does not
# unpack next to gmsh.py; repack it with the library beside the module, where gmsh.py looks first.
"$py" - "$wheels"/deps/gmsh-*.whl "$stage/wheels" <<'EOF'
import base64, csv, hashlib, io, os, sys, zipfile
src, dest = sys.argv[1], sys.argv[2]
name = os.path.basename(src)
out = os.path.join(dest, name)
records = []
with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
    dist_info = next(n.split("/")[0] for n in zin.namelist() if n.endswith(".dist-info/WHEEL"))
    for info in zin.infolist():
        n = info.filename
        if n.endswith("/"):
            continue
        if n == "gmsh.py":
            target = n
        elif "/data/lib/libgmsh.so" in n:
            target = os.path.basename(n)
        elif n.startswith(dist_info + "/") and not n.endswith("/RECORD"):
            target = n
        else:
            continue    # headers, docs, the gmsh executable wrapper, Julia API
        data = zin.read(n)
        zi = zipfile.ZipInfo(target, date_time=info.date_time)
        zi.external_attr = info.external_attr
        zi.compress_type = zipfile.ZIP_DEFLATED
        zout.writestr(zi, data)
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        records.append((target, f"sha256={digest}", str(len(data))))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerows(records + [(f"{dist_info}/RECORD", "", "")])
    zout.writestr(f"{dist_info}/RECORD", buf.getvalue())
EOF

cp "$wheels"/seamfit/seamfit-*.whl "$wheels"/deps/scipy-*.whl "$stage/wheels/"
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

"$bpy_py" - "$root/$stage" "$out" <<'EOF'
import sys
import bpy  # noqa: F401  (sets up Blender's module paths)
import addon_utils
from bl_pkg import bl_extension_cli
src, out = sys.argv[1], sys.argv[2]
sys.exit(bl_extension_cli.cli_extension_handler(["build", "--source-dir", src, "--output-dir", out]))
EOF
ls -la "$out"/seamfit-*.zip
