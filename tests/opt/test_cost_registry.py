"""The cost-term registry (native/core/opt/cost_terms.hpp) is the one list of fitting cost
terms: the built core, the CPU and GPU cost sets, Strengths, the presets and the command line
all take their terms from it, and the files that run and bind the terms name none. The
"Adding a cost term" diff in docs/architecture.md still applies and touches four files, and
the CPU core built with it applied passes the example's test (a few minutes)."""
from __future__ import annotations

import argparse
import ast
import os
import re
import shutil
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

import opt_synthetic as S
from common import REPO
from seamfit._native import core
from seamfit.opt import PRESETS, CostSet, Strengths
from seamfit.opt.costs import COST_TERM_NAMES, COST_TERMS, STRENGTH_HELP, STRENGTH_NAMES

REGISTRY = REPO / "native" / "core" / "opt" / "cost_terms.hpp"
# The files that evaluate, mirror or bind the terms: they iterate over the registry.
WIRING = ["native/core/opt/cost_set.hpp", "native/core/opt/cost_set.cpp", "native/core/opt/costs_gpu.hpp",
          "native/core/opt/costs_gpu.cu", "native/bindings/py_cost_set.hpp", "native/bindings/opt_costs.cpp",
          "native/bindings/cuda_opt.cpp"]
REGULARIZERS = ("fix", "cur", "seam")


def registered() -> list[tuple[str, str]]:
    """(struct, name) of each X(...) line of the registry, in order."""
    return re.findall(r'^\s*X\((\w+),\s*"(\w+)"', REGISTRY.read_text(), re.M)


def example_diff() -> str:
    """The diff under docs/architecture.md's "Adding a cost term"."""
    text = (REPO / "docs" / "architecture.md").read_text()
    section = text.split("## Adding a cost term", 1)[1]
    return re.search(r"^```diff\n(.*?)^```$", section, re.S | re.M).group(1)


def diff_paths(diff: str) -> list[str]:
    return re.findall(r"^diff --git a/(\S+) b/\S+$", diff, re.M)


def _run(cmd, **kw) -> subprocess.CompletedProcess:
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    assert p.returncode == 0, f"{cmd} -> {p.returncode}\n{p.stdout[-4000:]}\n{p.stderr[-3000:]}"
    return p


@pytest.fixture(scope="module")
def all_on():
    """A cost set with every registered term at strength 1, and the state to evaluate it at."""
    mesh = S.two_panels()
    xbar = S.wrapped_garment(mesh)
    rng = np.random.default_rng(11)
    x = 1.04 * xbar + rng.normal(0, 1e-3, xbar.shape)
    lo, hi = np.minimum(xbar, x).min(0) - 0.05, np.maximum(xbar, x).max(0) + 0.05
    sdf = S.sphere_sdf([0.0, 0.0, 0.9], 0.15, lo, hi, 0.0093)
    cs = CostSet(mesh, xbar, Strengths(**dict.fromkeys(COST_TERM_NAMES, 1.0)), target_sdf=sdf, phibar=np.zeros(len(x)),
                 xtilde=xbar + 0.01)
    return cs, x, mesh.uv_cm / 100.0


def test_the_core_was_built_from_the_registry():
    assert [name for _, name in registered()] == list(COST_TERM_NAMES)
    assert COST_TERMS == tuple(tuple(t) for t in core().COST_TERMS)
    assert len(set(COST_TERM_NAMES)) == len(COST_TERM_NAMES)
    for name, label, text in COST_TERMS:
        assert name.isidentifier() and name not in REGULARIZERS and label and text


def test_strengths_take_the_cost_terms_from_the_registry():
    assert STRENGTH_NAMES == ("fix", "cur", *COST_TERM_NAMES, "seam")
    assert tuple(f.name for f in fields(Strengths)) == STRENGTH_NAMES
    assert tuple(STRENGTH_HELP) == STRENGTH_NAMES
    for name, label, text in COST_TERMS:
        assert STRENGTH_HELP[name] == (label, text)
    assert all(getattr(Strengths(), name) == 0.0 for name in STRENGTH_NAMES)


def test_every_term_reports_its_value_and_its_evaluations(all_on):
    cs, x, p = all_on
    before = cs.evaluations
    v, terms, gx, gp = cs.evaluate(x, p)
    assert list(terms) == list(COST_TERM_NAMES) and all(terms[k] > 0 for k in terms)
    total = terms[COST_TERM_NAMES[0]]
    for name in COST_TERM_NAMES[1:]:
        total += terms[name]
    assert v == total                                  # summed in registry order
    assert cs.evaluations == {name: before[name] + 1 for name in COST_TERM_NAMES}
    for name in COST_TERM_NAMES:
        c = cs._native.constants(name)
        assert c.ndim == 2 and c.shape[0] > 0 and np.isfinite(c).all()


def test_the_native_cost_set_refuses_an_unknown_term(all_on):
    cs = all_on[0]
    with pytest.raises(ValueError, match="unknown cost term 'nope'; the terms are " + ", ".join(COST_TERM_NAMES)):
        cs._native.set_strengths({"nope": 1.0})
    with pytest.raises(ValueError, match="unknown cost term"):
        cs._native.constants("nope")


@pytest.mark.gpu
def test_the_gpu_cost_set_reports_every_registered_term(all_on):
    cs, x, p = all_on
    cpu = cs.evaluate(x, p)[1]
    cs.use_device("cuda")
    try:
        terms = cs.evaluate(x, p)[1]
    finally:
        cs.use_device("cpu")
    assert list(terms) == list(COST_TERM_NAMES)
    assert all(terms[k] == pytest.approx(cpu[k], rel=1e-12) for k in terms)


def test_presets_leave_a_term_they_do_not_name_off():
    # keyword arguments only: a term registered later gets Strengths' default, 0
    tree = ast.parse((REPO / "native" / "python" / "seamfit" / "opt" / "presets.py").read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", None) == "Strengths"]
    assert calls and all(not c.args and all(k.arg for k in c.keywords) for c in calls)
    named = {k.arg for c in calls for k in c.keywords}
    for p in PRESETS.values():
        assert all(getattr(p.strengths, name) == 0.0 for name in STRENGTH_NAMES if name not in named)


def test_the_command_line_has_a_strength_option_per_term():
    from seamfit.commands.grade import add_grade_options
    parser = argparse.ArgumentParser()
    add_grade_options(parser, truth=False)
    options = {o for a in parser._actions for o in a.option_strings}
    assert all(f"--{name}" in options for name in STRENGTH_NAMES)


@pytest.mark.parametrize("path", WIRING)
def test_the_cost_sets_and_bindings_name_no_term(path):
    text = (REPO / path).read_text()
    for struct, name in registered():
        found = re.search(rf'\bk?{struct}\b|"{name}"', text)
        assert found is None, f"{path} names the {name} term ({found.group(0)}): iterate over the registry"


def test_the_example_term_touches_four_files():
    diff = example_diff()
    paths = diff_paths(diff)
    assert len(paths) == 4 and "native/core/opt/cost_terms.hpp" in paths
    assert sum(re.fullmatch(r"native/core/opt/costs/\w+\.hpp", p) is not None for p in paths) == 1
    assert sum(re.fullmatch(r"tests/opt/test_\w+\.py", p) is not None for p in paths) == 1
    assert sum(re.fullmatch(r"docs/\w+\.md", p) is not None for p in paths) == 1
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout: the diff cannot be checked against the tree")
    check = subprocess.run(["git", "apply", "--check", "-"], cwd=REPO, input=diff, text=True, capture_output=True)
    assert check.returncode == 0, ("the example diff in docs/architecture.md no longer applies: make it again "
                                   "from the example term's four files\n" + check.stderr)


def test_the_example_term_builds_and_passes_its_test(tmp_path):
    """A copy of the tree with the example diff applied: the CPU core builds, and the example's
    test, the cost tests and this file's registry checks pass there with nothing else edited."""
    import pybind11
    diff = example_diff()
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=REPO,
                            capture_output=True, check=True).stdout.decode()
    src = tmp_path / "src"
    for name in filter(None, listed.split("\0")):
        if (REPO / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / name, src / name)
    _run(["git", "apply", "-"], cwd=src, input=diff)
    build = tmp_path / "build"
    cmake = shutil.which("cmake", path=str(Path(sys.executable).parent)) or "cmake"   # the venv's, else PATH's
    _run([cmake, "-S", src, "-B", build, "-DSEAMFIT_CUDA=OFF", f"-DPython_EXECUTABLE={sys.executable}",
          f"-Dpybind11_DIR={pybind11.get_cmake_dir()}"])
    _run([cmake, "--build", build, "--target", "_core", "-j", os.cpu_count() or 2])
    example = next(p for p in diff_paths(diff) if p.startswith("tests/"))
    env = {**os.environ, "PYTHONPATH": str(src / "native" / "python")}
    run = _run([sys.executable, "-m", "pytest", "-q", "-rA", "-p", "no:cacheprovider", example,
                "tests/opt/test_opt_costs.py", "tests/opt/test_cost_registry.py", "-k", "not example_term"],
               cwd=src, env=env)
    assert f"PASSED {example}::" in run.stdout
    # and it was the copy's module that ran
    check = _run([sys.executable, "-c", "import seamfit; print(seamfit.__file__)"], cwd=src, env=env)
    assert Path(check.stdout.strip()).is_relative_to(src)
