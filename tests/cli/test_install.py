"""A plain install, as CI's clean clone would make it: a copy of the source tree without
build outputs, a fresh venv, ``pip install .``, then ``seamfit drape`` and ``seamfit grade``
on a sample.

Only the build tools go into the venv beforehand (pip then builds without isolation, so no
second download of them per build); every run-time dependency must come from
pyproject.toml, so a missing declaration fails here. The package is built once per
session: compiling the C++ takes a few minutes on 2 cores.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from common import REPO

# Not in a clean clone: build outputs, venvs, caches, the in-place module.
NOT_CLONED = {".git", "build", "dist", "out", ".cache", ".pytest_cache", "__pycache__"}
QUICK = ["--edge-length", "5", "--sdf-spacing", "0.01"]


def _clone(dst: Path) -> None:
    """The files a clone of this working tree holds: git's tracked and not-ignored files
    (local scratch folders stay behind); without git, the tree minus build outputs."""
    try:
        listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                                cwd=REPO, capture_output=True, check=True).stdout.decode()
    except (OSError, subprocess.CalledProcessError):
        shutil.copytree(REPO, dst, ignore=_not_cloned)
        return
    for name in filter(None, listed.split("\0")):
        if (REPO / name).is_file():              # a tracked file deleted here stays deleted
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / name, dst / name)


def _not_cloned(folder, names):
    return {n for n in names if n in NOT_CLONED or n.startswith(".venv") or n.endswith((".egg-info", ".pyc"))
            or (n.startswith("_core") and n.endswith((".so", ".pyd")))}


def _env(**extra) -> dict:
    """This environment without a PYTHONPATH (it may point at the source tree)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(extra)
    return env


def _run(cmd, *, timeout, **kw) -> subprocess.CompletedProcess:
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout, **kw)
    assert p.returncode == 0, f"{cmd} -> {p.returncode}\n{p.stdout[-3000:]}\n{p.stderr[-5000:]}"
    return p


@pytest.fixture(scope="session")
def installed(tmp_path_factory):
    """(venv folder, source copy, environment for running the installed seamfit)."""
    base = tmp_path_factory.mktemp("install")
    src = base / "seamfit-src"
    _clone(src)
    venv = base / "venv"
    _run([sys.executable, "-m", "venv", venv], timeout=300)
    py = venv / "bin" / "python"
    build = tomllib.loads((src / "pyproject.toml").read_text())["build-system"]["requires"]
    _run([py, "-m", "pip", "install", "-q", *build, "cmake>=3.24", "ninja"], timeout=900, env=_env())
    # CPU backend only: the CUDA build is setup.sh's; packaging is what this tests.
    _run([py, "-m", "pip", "install", "-q", "--no-build-isolation", src], timeout=3000,
         env=_env(SEAMFIT_CUDA="OFF"), cwd=base)
    env = _env(SEAMFIT_CACHE_DIR=str(base / "cache"), MPLCONFIGDIR=str(base / "mpl"))
    return venv, src, env


def test_install_brings_every_runtime_import(installed):
    """pip's resolver found every declared dependency, and every module of the installed
    package imports with only those (lazy imports are exercised by the commands below)."""
    venv, _, env = installed
    py = venv / "bin" / "python"
    _run([py, "-m", "pip", "check"], timeout=120, env=env)
    code = ("import importlib, pkgutil, seamfit, matplotlib\n"
            "names = [m.name for m in pkgutil.walk_packages(seamfit.__path__, 'seamfit.') "
            "if m.name != 'seamfit.__main__']\n"
            "for n in names: importlib.import_module(n)\n"
            "print(seamfit.__file__, len(names))")
    p = _run([py, "-c", code], timeout=300, env=env, cwd=venv)
    assert str(venv) in p.stdout, p.stdout   # the installed copy, not the source tree


def test_installed_drape_and_grade_write_results(installed, tmp_path):
    venv, src, env = installed
    seamfit = venv / "bin" / "seamfit"
    samples = src / "sample_files"
    pattern = samples / "patterns/gc_pencil_skirt/size06/pattern.json"
    b0, b1 = samples / "bodies/women_size06.obj", samples / "bodies/women_size10.obj"

    _run([seamfit, "drape", pattern, b0, "--out", tmp_path / "drape", *QUICK, "-q"],
         timeout=600, env=env, cwd=tmp_path)
    report = json.loads((tmp_path / "drape/report.json").read_text())
    assert (tmp_path / "drape/garment.obj").exists()
    assert report["pictures"] == {"drape.png": {"written": True}}
    assert (tmp_path / "drape/drape.png").read_bytes()[:4] == b"\x89PNG"

    p = _run([seamfit, "grade", pattern, "--base-body", b0, "--target-body", b1, "--out", tmp_path / "grade",
              *QUICK, "--max-iterations", "2"], timeout=900, env=env, cwd=tmp_path)
    out = tmp_path / "grade"
    for name in ("pattern.json", "pattern.svg", "garment.obj", "report.json", "pattern.png", "drape.png"):
        assert (out / name).exists(), (name, p.stderr[-3000:])
    report = json.loads((out / "report.json").read_text())
    assert report["outer_iterations"] <= 2
    assert all(s["written"] for s in report["pictures"].values()), report["pictures"]
    assert "not drawn" not in p.stderr and "Traceback" not in p.stderr, p.stderr[-3000:]


def test_installed_body_from_measurements(installed, tmp_path):
    """The body model's packed data is in the wheel: a body is made with nothing downloaded."""
    venv, _, env = installed
    (tmp_path / "tape.json").write_text(json.dumps({"units": "cm", "measurements": {"height": 170, "hip": 100}}))
    _run([venv / "bin" / "seamfit", "body", "--measurements", tmp_path / "tape.json", "--out", tmp_path / "me.obj",
          "-q"], timeout=300, env=env, cwd=tmp_path)
    (body,) = json.loads((tmp_path / "me.report.json").read_text())["bodies"]
    assert body["met"] and body["set"] == ["height", "hip"], body
    assert (tmp_path / "me.obj").stat().st_size > 500_000
