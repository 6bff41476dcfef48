"""Importing (and measuring), while the GIL is free, what a run needs later.

A cold grading spends about a second building the body fields in compiled code that
releases the GIL, while scipy.optimize (the curve refit) and matplotlib (the pictures)
take 0.5-1 s to import and are needed only after the search. ``want`` names such modules;
``start``, called as the body fields begin, imports them on one background thread, in
order: scipy.spatial (the level scaling's hulls, right after the fields; seamfit.opt.fit)
goes first. ``want`` also takes a function to call there (the two bodies' measurements,
which the level scaling takes right after the fields). An import or a call that fails
there is left to fail where it is needed, with its own message; the interpreter waits for
the thread before it exits.
"""
from __future__ import annotations

import atexit
import importlib
import sys
import threading

__all__ = ["want", "start"]

_wanted: list = []
_thread: threading.Thread | None = None


def want(*names, first: bool = False) -> None:
    """Modules this run will import later (loaded by the next ``start``), or functions of
    no arguments to call there, once; ``first``: ahead of those already named, for what is
    needed right after the body fields."""
    names = list(dict.fromkeys(names))
    if first:
        _wanted[:] = names + [n for n in _wanted if n not in names]
    else:
        _wanted.extend(n for n in names if n not in _wanted)


def start(*names: str) -> None:
    """Import the wanted modules (and ``names``) on a background thread, once."""
    global _thread
    want(*names)
    todo = [n for n in _wanted if callable(n) or n not in sys.modules]
    if not todo or (_thread is not None and _thread.is_alive()):
        return
    _wanted[:] = [n for n in _wanted if not callable(n)]     # a call runs once
    _thread = threading.Thread(target=_load, args=(todo,), name="seamfit-preload", daemon=True)
    _thread.start()


def _load(names: list) -> None:
    for n in names:
        try:
            if callable(n):
                n()
                continue
            if n == "matplotlib.pyplot":
                import matplotlib
                matplotlib.use("Agg")   # as the renderers do: no GUI backend is chosen
            importlib.import_module(n)
        except Exception:   # noqa: BLE001 - it fails again, and says why, where it is used
            pass


@atexit.register
def _join() -> None:
    # An import cut off by the interpreter's shutdown can crash it.
    if _thread is not None:
        _thread.join(timeout=30)
