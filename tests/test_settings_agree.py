"""Every grading setting has one default: seamfit.opt.grade.GradeSettings (and the
simulator's SimSettings). The command line takes its defaults from them; the add-on's
scene properties are Blender literals, so this test reads them from addon/props.py (no
Blender needed) and fails where a front end shows another default than the one seamfit
grades with."""
import argparse
import ast
from pathlib import Path

import pytest

from seamfit.commands.grade import add_grade_options
from seamfit.opt.grade import GradeSettings
from seamfit.sim.model import SimSettings

PROPS = Path(__file__).resolve().parents[1] / "addon" / "props.py"


def _addon_defaults(cls: str = "SEAMFIT_PG_settings") -> dict:
    """{property: default} of the literal defaults in the add-on's scene settings group."""
    tree = ast.parse(PROPS.read_text())
    group = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == cls)
    out = {}
    for stmt in group.body:
        if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.annotation, ast.Call):
            for kw in stmt.annotation.keywords:
                if kw.arg == "default" and isinstance(kw.value, ast.Constant):
                    out[stmt.target.id] = kw.value.value
    return out


def _cli_defaults() -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add_grade_options(p, truth=True)
    return p.parse_args([])


# add-on property -> (GradeSettings field or SimSettings field, conversion to seamfit's unit)
ADDON = {
    "iterations": ("grade", "max_outer_iterations", int),
    "exact_every": ("grade", "checkpoint_every", int),
    "steps_per_iteration": ("grade", "inner_iterations", int),
    "sdf_spacing_mm": ("grade", "sdf_spacing", lambda mm: mm / 1000.0),
    "device": ("grade", "device", str.lower),
    "mu": ("sim", "mu", float),
    "sim_iterations": ("sim", "max_iterations", int),
}

# command-line option (dest) -> GradeSettings field
CLI = {
    "method": "method", "start": "start", "preset": "preset", "edge_length": "edge_length_cm",
    "coarse_edge_length": "coarse_edge_length_cm", "fine_iterations": "fine_outer_iterations",
    "sdf_spacing": "sdf_spacing", "sdf_region": "sdf_region", "sdf_margin": "sdf_region_margin",
    "inner_iterations": "inner_iterations", "checkpoint_every": "checkpoint_every",
    "max_iterations": "max_outer_iterations", "stop_move_mm": "stop_move_mm", "time_budget": "time_budget_s",
    "report_base_pattern": "evaluate_base_pattern", "device": "device", "adjoint_forcing": "adjoint_forcing",
}


@pytest.mark.parametrize("prop", sorted(ADDON))
def test_the_addon_shows_seamfits_defaults(prop):
    found = _addon_defaults()
    assert prop in found, f"addon/props.py: no literal default for {prop}"
    where, name, to_seamfit = ADDON[prop]
    want = getattr(GradeSettings() if where == "grade" else SimSettings(), name)
    assert to_seamfit(found[prop]) == pytest.approx(want), (
        f"the add-on's {prop} defaults to {found[prop]!r}, seamfit's {name} to {want!r}")


@pytest.mark.parametrize("dest", sorted(CLI))
def test_the_command_line_shows_seamfits_defaults(dest):
    got, want = getattr(_cli_defaults(), dest), getattr(GradeSettings(), CLI[dest])
    assert got == want, f"seamfit grade --{dest.replace('_', '-')} defaults to {got!r}, GradeSettings to {want!r}"


def test_the_guard_sees_a_disagreement(tmp_path, monkeypatch):
    """The add-on reader finds a changed default, so the tests above can fail."""
    import re
    import sys
    changed = tmp_path / "props.py"
    changed.write_text(re.sub(r'(name="Outer iterations", default=)\d+', r"\g<1>99999", PROPS.read_text()))
    monkeypatch.setattr(sys.modules[__name__], "PROPS", changed)
    assert _addon_defaults()["iterations"] == 99999
