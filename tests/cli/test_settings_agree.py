"""Every user setting has one definition: its field in GradeSettings, SimSettings or Fabric,
declared with seamfit.settings.setting. The command line, the batch jobs, the add-on's
scene properties, a report's echo and docs/settings.md are made from it; these tests fail
where a front end defines a setting, or shows a default, of its own."""
import argparse
import ast
import dataclasses
from pathlib import Path

import pytest

from seamfit import settings
from seamfit.cli import build_parser
from seamfit.commands.grade import add_grade_options
from seamfit.opt.grade import GradeSettings
from seamfit.sim.model import Fabric, SimSettings
from common import REPO

PROPS = REPO / "addon" / "props.py"
OWNERS = {"grade": GradeSettings, "sim": SimSettings, "fabric": Fabric}
TABLE = settings.table()


def _command_defaults(command: str) -> argparse.Namespace:
    """``seamfit COMMAND``'s options with nothing given (its required arguments filled in)."""
    required = {"grade": ["p", "--base-body", "b", "--target-body", "t", "--out", "o"],
                "drape": ["p", "b", "--out", "o"], "mesh": ["p", "--out", "o"]}[command]
    return build_parser().parse_args([command, *required])


def test_the_table_is_read_from_the_fields():
    """Each row is its field: same default, and every owner's user settings are in it."""
    for key, s in TABLE.items():
        f = {f.name: f for f in dataclasses.fields(OWNERS[s.owner])}[s.name]
        assert f.default == s.default, key
        s.check(s.default, key)     # a default inside its own range
    assert {"grade.max_outer_iterations", "grade.checkpoint_every", "sim.mu", "fabric.density"} <= set(TABLE)


@pytest.mark.parametrize("command", ["grade", "drape", "mesh"])
def test_each_command_shows_the_table_defaults(command):
    args = _command_defaults(command)
    rows = settings.for_command(command)
    assert rows
    for s in rows:
        assert getattr(args, s.dest) == s.default, f"seamfit {command} {s.flag}"


def test_the_batch_jobs_take_the_grade_options():
    from seamfit.batch import settings as batch
    p = argparse.ArgumentParser()
    add_grade_options(p, truth=False)
    for s in settings.for_command("batch"):
        assert batch.defaults()[s.dest] == s.default
        assert batch.option_of(s.dest) == max([s.flag] + ([s.short] if s.short else []), key=len)


def test_a_range_is_checked_where_the_option_is_read():
    """An option outside its setting's range is refused, naming the option, by the same check
    GradeSettings.validate runs."""
    from seamfit.commands.grade import check_grade_numbers
    from seamfit.errors import SeamfitError, SolveError
    args = _command_defaults("grade")
    args.checkpoint_every = 0
    with pytest.raises(SeamfitError, match="--checkpoint-every 0: must be >= 1"):
        check_grade_numbers(args)
    args = _command_defaults("grade")
    args.adjoint_forcing = 1.0
    with pytest.raises(SeamfitError, match="--adjoint-forcing 1: must be < 1"):
        check_grade_numbers(args)
    with pytest.raises(SolveError, match="adjoint_forcing 1: must be < 1"):
        GradeSettings(adjoint_forcing=1.0).validate()
    with pytest.raises(SolveError, match="edge_length_cm nan: must be a finite number"):
        GradeSettings(edge_length_cm=float("nan")).validate()


def _addon_declarations(path: Path = PROPS) -> dict:
    """{property: its annotation's source} of the add-on's scene settings group."""
    tree = ast.parse(path.read_text())
    group = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == "SEAMFIT_PG_settings")
    return {stmt.target.id: ast.unparse(stmt.annotation) for stmt in group.body if isinstance(stmt, ast.AnnAssign)}


def _addon_disagreements(path: Path = PROPS) -> list[str]:
    declared = _addon_declarations(path)
    wrong = []
    for key, s in TABLE.items():
        if s.addon is None:
            continue
        want = f"_setting({key!r})"
        if declared.get(s.addon.prop) != want:
            wrong.append(f"{s.addon.prop}: {declared.get(s.addon.prop)} (want {want})")
    return wrong


def test_the_addon_declares_its_settings_from_the_table():
    assert _addon_disagreements() == []


def test_the_guard_sees_a_property_of_its_own(tmp_path):
    """A property typed out by hand (its own default) is found, so the test above can fail."""
    changed = tmp_path / "props.py"
    changed.write_text(PROPS.read_text().replace('_setting("grade.max_outer_iterations")',
                                                 'IntProperty(name="Outer iterations", default=256)'))
    assert _addon_disagreements(changed) == [
        "iterations: IntProperty(name='Outer iterations', default=256) (want _setting('grade.max_outer_iterations'))"]


@pytest.mark.parametrize("key", sorted(k for k, s in TABLE.items() if s.addon is not None))
def test_the_addon_property_round_trips_seamfits_value(key):
    """The property's default is seamfit's, in the unit shown; read back, it is seamfit's value."""
    s = TABLE[key]
    kw = settings.blender_property(key)
    assert kw["default"] == settings.to_blender(key, s.default)
    assert settings.from_blender(key, kw["default"]) == pytest.approx(s.default)
    if "min" in kw:
        assert kw["min"] <= kw["default"]
    if s.choices:
        assert [item[0] for item in kw["items"]] == [c.upper() for c in s.choices]


def test_a_report_echoes_the_settings():
    g = GradeSettings(max_outer_iterations=7)
    echoed = settings.echo(g, "grade")
    assert set(echoed) == {s.name for s in TABLE.values() if s.owner == "grade"}
    assert echoed["max_outer_iterations"] == 7


def test_the_docs_reference_is_current():
    page = (REPO / "docs" / "settings.md").read_text()
    assert page == settings.reference(), "docs/settings.md is stale: python -m seamfit.settings > docs/settings.md"
