"""Background imports during the body fields (seamfit.preload): the wanted modules are
imported on another thread, once; one that cannot be imported costs nothing there."""
from __future__ import annotations

import sys

from seamfit import preload


def test_wanted_modules_are_imported_in_the_background(monkeypatch):
    monkeypatch.setattr(preload, "_wanted", [])
    monkeypatch.setattr(preload, "_thread", None)
    sys.modules.pop("colorsys", None)
    preload.want("colorsys", "seamfit_no_such_module")
    preload.want("colorsys")                      # named twice, wanted once
    assert preload._wanted == ["colorsys", "seamfit_no_such_module"]
    preload.start()
    t = preload._thread
    assert t is not None and t.daemon
    t.join(timeout=30)
    assert "colorsys" in sys.modules and "seamfit_no_such_module" not in sys.modules
    # nothing left to import: no new thread
    monkeypatch.setattr(preload, "_wanted", ["colorsys"])
    preload.start()
    assert preload._thread is t


def test_a_grading_wants_the_refit_and_the_command_its_pictures():
    """The refit's scipy.optimize is no longer imported with seamfit.pattern, so the
    preload has something to do; the grading still refits (tests/test_grade.py)."""
    import seamfit.pattern.refit as refit
    assert "least_squares" not in vars(refit)
