"""Pictures come after results.

``drape`` and ``grade`` write their pattern, mesh and report first and draw their pictures
(matplotlib) last, into the same output-set folder. A picture that cannot be drawn,
because matplotlib is missing (Blender's Python, a ``--no-deps`` install) or the drawing
fails, costs only that picture: one warning line on stderr and a ``pictures`` entry in
the report saying which picture is missing and why.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Callable, Mapping

NOT_INSTALLED = "matplotlib is not installed (pip install matplotlib draws it)"
SKIPPED = "--no-picture"


def draw_pictures(folder: Path, drawers: Mapping[str, Callable[[Path], object]], *, command: str) -> dict:
    """Draw each ``folder / name`` with its drawer. Returns the report's ``pictures`` entry,
    ``{name: {"written": True}}`` or ``{name: {"written": False, "reason": ...}}``, after one
    warning line on stderr per reason for the pictures that are missing."""
    status = {}
    for name, draw in drawers.items():
        path = Path(folder) / name
        try:
            draw(path)
            status[name] = {"written": True}
        except Exception as exc:                 # Ctrl-C and SIGTERM still abort the whole set
            path.unlink(missing_ok=True)
            status[name] = {"written": False, "reason": failure_reason(exc)}
    warn_missing(status, command)
    return status


def skipped(names) -> dict:
    """The ``pictures`` entry when --no-picture asked for none."""
    return {name: {"written": False, "reason": SKIPPED} for name in names}


def written(status: Mapping[str, dict]) -> list[str]:
    return [name for name, s in status.items() if s.get("written")]


def failure_reason(exc: BaseException) -> str:
    """One short line: what kept a picture from being drawn."""
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] == "matplotlib":
        return NOT_INSTALLED
    lines = str(exc).strip().splitlines()
    what = f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__
    if isinstance(exc, ImportError):             # matplotlib is there but one of its parts is not
        return f"matplotlib cannot be imported ({what})"[:300]
    return f"drawing failed ({what})"[:300]


def warn_missing(status: Mapping[str, dict], command: str) -> None:
    """One stderr line per reason (a missing matplotlib names every picture at once); shown
    even with -q, since a file the user expects is not there."""
    by_reason: dict[str, list[str]] = {}
    for name, s in status.items():
        if not s.get("written") and s.get("reason") != SKIPPED:
            by_reason.setdefault(s["reason"], []).append(name)
    for reason, names in by_reason.items():
        print(f"seamfit {command}: warning: {', '.join(names)} not drawn: {reason}; the other results "
              "are written", file=sys.stderr, flush=True)
