"""A job's settings: the options of ``seamfit grade`` (one definition, from
``seamfit.commands.grade.add_grade_options``), given by their names without dashes
(``edge_length``, ``max_iterations``, ``preset``, ...), checked as ``grade`` checks them and
turned back into command-line options for the job's process."""
from __future__ import annotations

import argparse
from functools import lru_cache

# Options of grade that are the batch's own business, not a job's setting.
NOT_SETTINGS = {"help", "force", "quiet", "truth"}


@lru_cache(maxsize=1)
def _actions() -> dict:
    from ..commands.grade import add_grade_options
    p = argparse.ArgumentParser(add_help=False)
    add_grade_options(p, truth=True)
    return {a.dest: a for a in p._actions if a.dest not in NOT_SETTINGS}


def setting_names() -> list[str]:
    return sorted(_actions())


def defaults() -> dict:
    return {name: a.default for name, a in _actions().items()}


def convert(name: str, value):
    """``value`` (from JSON, or a CSV cell's text) as the option ``name`` takes it; a
    ValueError says why not."""
    a = _actions()[name]
    if isinstance(a, argparse._StoreTrueAction):
        if isinstance(value, bool):
            return value
        text = str(value).strip().lower()
        if text in ("1", "true", "yes"):
            return True
        if text in ("0", "false", "no", ""):
            return False
        raise ValueError(f"{value!r} is not true or false")
    if isinstance(value, bool) or value is None or isinstance(value, (list, dict)):
        raise ValueError(f"{value!r} is not a {'number' if a.type in (int, float) else 'value'}")
    if a.type is int and isinstance(value, float):
        if not value.is_integer():
            raise ValueError(f"{value!r} is not a whole number")
        value = int(value)
    try:
        out = a.type(value) if a.type is not None else str(value)
    except (TypeError, ValueError):
        kind = {int: "a whole number", float: "a number"}.get(a.type, "a value")
        raise ValueError(f"{value!r} is not {kind}") from None
    if a.choices is not None and out not in a.choices:
        raise ValueError(f"{out!r} is not one of {', '.join(map(str, a.choices))}")
    return out


def checked(values: dict) -> argparse.Namespace:
    """Every setting (the grade defaults, then ``values``), with grade's own checks of the
    numbers; SeamfitError names the option at fault."""
    from ..commands.grade import check_grade_numbers
    ns = argparse.Namespace(**{**defaults(), **values})
    check_grade_numbers(ns)
    return ns


def option_of(name: str) -> str:
    return max(_actions()[name].option_strings, key=len)


def to_argv(values: dict) -> list[str]:
    """The command-line options that give ``values`` (defaults left out), in a fixed order."""
    argv = []
    d = defaults()
    for name in sorted(values):
        v = values[name]
        if v == d[name] or v is None:
            continue
        if isinstance(v, bool):
            argv.append(option_of(name))
        else:
            # float(): a numpy float is a float too, and its repr is "np.float64(...)" from numpy 2 on
            argv += [option_of(name), repr(float(v)) if isinstance(v, float) else str(v)]
    return argv

