"""Every setting a user can give seamfit, declared once.

A setting is a field of ``GradeSettings`` (seamfit.opt.grade), ``SimSettings`` or ``Fabric``
(seamfit.sim.model) declared with :func:`setting`: its default, help, unit, range and the
front ends that show it sit beside the field. Everything else is read from there:

- the command line's options (:func:`add_options`, for ``grade``, ``grade-run``, the batch
  jobs and ``drape``) and their checks (:func:`check_options`);
- the Blender add-on's scene properties (:func:`blender_property`);
- the settings a report echoes (:func:`echo`);
- the settings reference in ``docs/settings.md`` (:func:`reference`).

Fields declared without :func:`setting` are the solver's own, not a user's to set.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, Optional

__all__ = ["Addon", "DRAPE", "GRADE", "Setting", "add_options", "blender_kind", "blender_property", "check_fields",
           "check_options", "echo", "for_command", "from_blender", "from_options", "get", "reference", "setting",
           "table", "to_blender", "typed_decimal"]

# The command-line commands a setting can appear in.
GRADE = ("grade", "grade-run", "batch")
DRAPE = ("drape",)


@dataclass(frozen=True)
class Addon:
    """How the Blender add-on shows a setting: its scene property (the name saved in .blend
    files), label, and the factor from seamfit's unit to the one shown (1000: metres shown
    as millimetres); ``soft_min``/``soft_max`` bound the slider, ``minimum`` the field."""
    prop: str
    label: str
    scale: float = 1.0
    minimum: Optional[float] = None
    maximum: Optional[float] = None
    soft_max: Optional[float] = None
    precision: Optional[int] = None


@dataclass(frozen=True)
class Setting:
    """One user setting. ``low``/``high`` bound it (``low_open``: strictly above ``low``);
    ``commands`` are the command-line commands that take it as ``flag``."""
    name: str
    owner: str                     # grade | sim | fabric
    kind: type                     # int | float | str | bool
    default: Any
    help: str
    unit: str = ""
    choices: tuple = ()
    choice_help: tuple = ()        # one line per choice, for the add-on's menu
    choice_labels: tuple = ()      # the add-on menu's names of the choices (default: capitalized)
    low: Optional[float] = None
    low_open: bool = False
    high: Optional[float] = None
    high_open: bool = False
    flag: Optional[str] = None
    short: Optional[str] = None
    metavar: Optional[str] = None
    commands: tuple = ()
    addon: Optional[Addon] = None

    @property
    def dest(self) -> str:
        """The option's name without dashes: argparse's attribute and the batch's setting name."""
        return self.flag.lstrip("-").replace("-", "_")

    def check(self, value, where: str) -> None:
        """ValueError naming ``where`` when ``value`` is outside the setting's choices or range."""
        if self.choices and value not in self.choices:
            raise ValueError(f"unknown {where} {value!r}; choose one of {', '.join(map(str, self.choices))}")
        if self.kind not in (int, float) or value is None:
            return
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{where} {value!r}: must be a finite number")
        if self.kind is int and float(value) != int(value):
            raise ValueError(f"{where} {value!r}: must be a whole number")
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            raise ValueError(f"{where} {value:g}: must be {'>' if self.low_open else '>='} {self.low:g}")
        if self.high is not None and (value >= self.high if self.high_open else value > self.high):
            raise ValueError(f"{where} {value:g}: must be {'<' if self.high_open else '<='} {self.high:g}")

    def range_text(self) -> str:
        parts = []
        if self.low is not None:
            parts.append(f"{'>' if self.low_open else '>='} {self.low:g}")
        if self.high is not None:
            parts.append(f"{'<' if self.high_open else '<='} {self.high:g}")
        return ", ".join(parts)


def setting(default, help: str, **spec):
    """A dataclass field that is a user setting (see :class:`Setting` for ``spec``)."""
    return field(default=default, metadata={"setting": (help, spec)})


def _owners():
    # Imported here: the settings' own modules import this one.
    from .opt.grade import GradeSettings
    from .sim.model import Fabric, SimSettings
    return {"grade": GradeSettings, "sim": SimSettings, "fabric": Fabric}


_TABLE: Optional[dict] = None


def table() -> dict[str, Setting]:
    """Every user setting by ``owner.name`` (e.g. ``grade.max_outer_iterations``), in
    declaration order."""
    global _TABLE
    if _TABLE is None:
        out = {}
        for owner, cls in _owners().items():
            for f in fields(cls):
                if "setting" not in f.metadata:
                    continue
                help_, spec = f.metadata["setting"]
                spec = dict(spec)
                default = f.default if f.default is not MISSING else None
                kind = spec.pop("kind", None) or type(default)
                out[f"{owner}.{f.name}"] = Setting(name=f.name, owner=owner, kind=kind, default=default,
                                                   help=help_, **spec)
        _TABLE = out
    return _TABLE


def get(key: str) -> Setting:
    return table()[key]


def for_command(command: str) -> list[Setting]:
    return [s for s in table().values() if command in s.commands]


# ---------------------------------------------------------------------------
# The command line

def add_options(parser: argparse.ArgumentParser, command: str) -> None:
    """The options of ``command`` (grade, grade-run, batch or drape) from the table."""
    for s in for_command(command):
        names = [s.flag] + ([s.short] if s.short else [])
        if s.kind is bool:
            parser.add_argument(*names, dest=s.dest, action="store_true", default=s.default, help=_cli_help(s))
            continue
        parser.add_argument(*names, dest=s.dest, type=s.kind, default=s.default, metavar=s.metavar,
                            choices=list(s.choices) or None, help=_cli_help(s))


def _cli_help(s: Setting) -> str:
    if s.kind is bool:
        return s.help
    default = f"{s.default:g}" if isinstance(s.default, float) else str(s.default)
    unit = f" {s.unit}" if s.unit and s.kind in (int, float) else ""
    return f"{s.help} (default {default}{unit})".replace("%", "%%")


def check_options(args: argparse.Namespace, command: str) -> None:
    """The options of ``command`` as :func:`add_options` defined them, each checked against
    its setting's choices and range; SeamfitError names the option."""
    from .errors import SeamfitError
    for s in for_command(command):
        if not hasattr(args, s.dest):
            continue
        try:
            s.check(getattr(args, s.dest), s.flag)
        except ValueError as exc:
            raise SeamfitError(str(exc)) from None


def from_options(args: argparse.Namespace, owner: str, command: str) -> dict:
    """{field: value} of ``owner``'s settings given by ``command``'s options."""
    return {s.name: getattr(args, s.dest) for s in for_command(command) if s.owner == owner}


def check_fields(obj, owner: str) -> None:
    """ValueError naming the field when a setting of ``obj`` is outside its choices or range."""
    for s in table().values():
        if s.owner == owner:
            s.check(getattr(obj, s.name), s.name)


# ---------------------------------------------------------------------------
# The add-on, the report and the docs

def blender_property(key: str) -> dict:
    """The keyword arguments of the add-on's scene property for setting ``key``; pass them
    to bpy.props' property of the setting's kind (:func:`blender_kind`)."""
    s = get(key)
    a = s.addon
    kw: dict = {"name": a.label, "description": s.help[:1].upper() + s.help[1:]}
    if s.choices:
        helps = s.choice_help or ("",) * len(s.choices)
        labels = s.choice_labels or tuple(c.capitalize() for c in s.choices)
        kw["items"] = [(c.upper(), label, h) for c, label, h in zip(s.choices, labels, helps)]
        kw["default"] = s.default.upper()
        return kw
    kw["default"] = s.default * a.scale if s.kind is float else s.default
    minimum = a.minimum if a.minimum is not None else (s.low * a.scale if s.low is not None else None)
    if minimum is not None:
        kw["min"] = minimum if s.kind is float else int(minimum)
    maximum = a.maximum if a.maximum is not None else (s.high * a.scale if s.high is not None else None)
    if maximum is not None:
        kw["max"] = maximum if s.kind is float else int(maximum)
    if a.soft_max is not None:
        kw["soft_max"] = a.soft_max if s.kind is float else int(a.soft_max)
    if a.precision is not None:
        kw["precision"] = a.precision
    return kw


def blender_kind(key: str) -> str:
    """bpy.props' property type for setting ``key``."""
    s = get(key)
    return "EnumProperty" if s.choices else {int: "IntProperty", float: "FloatProperty",
                                             bool: "BoolProperty", str: "StringProperty"}[s.kind]


def from_blender(key: str, value):
    """The seamfit value of setting ``key`` from its add-on property's ``value``."""
    s = get(key)
    if s.choices:
        return str(value).lower()
    if s.kind is float:
        return typed_decimal(value) / s.addon.scale
    return s.kind(value)


def typed_decimal(value: float) -> float:
    """The decimal a user typed, from Blender's float32 property: 0.05 stays 0.05 (not
    0.0500000007), so the add-on hands seamfit the same numbers as the command line."""
    import numpy as np
    return float(str(np.float32(value)))


def to_blender(key: str, value):
    """The add-on property's value for seamfit's ``value`` of setting ``key``."""
    s = get(key)
    if s.choices:
        return str(value).upper()
    return value * s.addon.scale if s.kind is float else s.kind(value)


def echo(obj, owner: str) -> dict:
    """{name: value} of ``obj``'s user settings, for a report."""
    return {s.name: getattr(obj, s.name) for s in table().values() if s.owner == owner}


def reference() -> str:
    """docs/settings.md: every setting, where it is shown, its default, unit and range."""
    lines = ["# Settings", "",
             "Every setting seamfit takes, generated from its one declaration (`seamfit.settings`;",
             "the fields of `GradeSettings`, `SimSettings` and `Fabric`). The command line, the",
             "Blender add-on, the batch jobs and a report's `settings` all read them from there;",
             "`tests/cli/test_settings_agree.py` fails when this page is not regenerated",
             "(`python -m seamfit.settings > docs/settings.md`).", ""]
    titles = {"grade": "Grading (`GradeSettings`)", "sim": "Simulation (`SimSettings`)",
              "fabric": "Fabric (`Fabric`)"}
    for owner, title in titles.items():
        lines += [f"## {title}", "", "| setting | default | unit | range | command line | add-on | what it does |",
                  "|---|---|---|---|---|---|---|"]
        for s in table().values():
            if s.owner != owner:
                continue
            cli = f"`{s.flag}`" + (f" / `{s.short}`" if s.short else "") + f" ({', '.join(s.commands)})" \
                if s.flag else ""
            addon = f"{s.addon.label}" if s.addon else ""
            rng = " \\| ".join(s.choices) if s.choices else s.range_text()
            default = f"{s.default:g}" if isinstance(s.default, float) else str(s.default)
            lines.append(f"| `{s.name}` | {default} | {s.unit} | {rng} | {cli} | {addon} | {s.help} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(reference(), end="")
