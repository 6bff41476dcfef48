# SPDX-License-Identifier: GPL-3.0-or-later
"""Third-party wheels as the seamfit extension ships them (used by scripts/build_addon.sh).

    python scripts/addon_wheels.py gmsh  GMSH_WHEEL  DEST
    python scripts/addon_wheels.py scipy SCIPY_WHEEL DEST SEAMFIT_SOURCES
    python scripts/addon_wheels.py size  ZIP...

gmsh: its wheel keeps libgmsh in <prefix>/lib, which Blender's wheel installer does not unpack
next to gmsh.py; the library goes beside the module, where gmsh.py looks first, and the
headers, docs, examples and the Julia API stay out.

scipy: only the subpackages seamfit's sources import and what those import in turn (found by
importing them from the wheel itself), without the test suites.

size: each extension zip's size and what it installs (the unpacked zip, wheels included, and
the wheels' contents).
"""
from __future__ import annotations

import base64
import csv
import hashlib
import io
import os
import re
import subprocess
import sys
import tempfile
import zipfile


def _repack(src: str, dest: str, rename) -> int:
    """Copy wheel ``src`` into folder ``dest``, each member under ``rename(name)`` (None: left
    out), with a new RECORD. Returns the bytes left out."""
    out = os.path.join(dest, os.path.basename(src))
    records, dropped = [], 0
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        dist_info = next(n.split("/")[0] for n in zin.namelist() if n.endswith(".dist-info/WHEEL"))
        for info in zin.infolist():
            n = info.filename
            if n.endswith("/") or n == f"{dist_info}/RECORD":
                continue
            target = n if n.startswith(dist_info + "/") else rename(n)
            if target is None:
                dropped += info.file_size
                continue
            data = zin.read(n)
            zi = zipfile.ZipInfo(target, date_time=info.date_time)
            zi.external_attr, zi.compress_type = info.external_attr, zipfile.ZIP_DEFLATED
            zout.writestr(zi, data)
            digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
            records.append((target, f"sha256={digest}", str(len(data))))
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerows(records + [(f"{dist_info}/RECORD", "", "")])
        zout.writestr(f"{dist_info}/RECORD", buf.getvalue())
    return dropped


def gmsh(src: str, dest: str) -> None:
    def rename(n: str):
        if n == "gmsh.py":
            return n
        if "/data/lib/libgmsh.so" in n:
            return os.path.basename(n)
        return None     # headers, docs, the gmsh executable wrapper, Julia API
    _repack(src, dest, rename)


def scipy_used(src: str, sources: str) -> set[str]:
    """The scipy subpackages seamfit needs."""
    used = set()
    for folder, _, files in os.walk(sources):
        for f in files:
            if f.endswith(".py"):
                with open(os.path.join(folder, f), encoding="utf-8") as fh:
                    used |= set(re.findall(r"\bscipy((?:\.[A-Za-z_]\w*)+)", fh.read()))
    with tempfile.TemporaryDirectory() as tmp:
        zipfile.ZipFile(src).extractall(tmp)
        # A name may end in a class or function (scipy.sparse.csr_matrix): import the longest
        # prefix that is a module.
        probe = (f"import importlib, sys\nsys.path.insert(0, {tmp!r})\n"
                 f"for name in {sorted(used)!r}:\n"
                 "    parts = name.strip('.').split('.')\n"
                 "    for k in range(len(parts), 0, -1):\n"
                 "        try:\n"
                 "            importlib.import_module('scipy.' + '.'.join(parts[:k]))\n"
                 "            break\n"
                 "        except ImportError:\n"
                 "            pass\n"
                 "print(' '.join(sorted({m.split('.')[1] for m in sys.modules if m.startswith('scipy.')})))")
        # -I: the wheel's scipy, not one installed in this Python.
        proc = subprocess.run([sys.executable, "-I", "-c", probe], capture_output=True, text=True)
        if proc.returncode:
            sys.exit(f"addon_wheels: importing {src}'s scipy failed:\n{proc.stderr}")
    return set(proc.stdout.split())


def scipy(src: str, dest: str, sources: str) -> None:
    keep = scipy_used(src, sources)

    def rename(n: str):
        parts = n.split("/")
        if parts[0] == "scipy" and (len(parts) > 2 and parts[1] not in keep or "tests" in parts[1:-1]):
            return None
        return n
    dropped = _repack(src, dest, rename)
    print(f"addon_wheels: scipy with {', '.join(sorted(keep))}; {dropped / 1e6:.0f} MB of other subpackages "
          "and tests left out")


def size(paths: list[str]) -> None:
    for path in paths:
        with zipfile.ZipFile(path) as z:
            # Blender keeps the unpacked zip (wheels included) and installs the wheels beside it.
            total = 0
            for info in z.infolist():
                total += info.file_size
                if info.filename.endswith(".whl"):
                    with zipfile.ZipFile(io.BytesIO(z.read(info))) as w:
                        total += sum(i.file_size for i in w.infolist())
        print(f"{path}: {os.path.getsize(path) / 1e6:.1f} MB, installs {total / 1e6:.0f} MB")


if __name__ == "__main__":
    what, args = sys.argv[1], sys.argv[2:]
    {"gmsh": gmsh, "scipy": scipy, "size": lambda *a: size(list(a))}[what](*args)
