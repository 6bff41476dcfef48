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


def test_a_module_wanted_first_goes_ahead(monkeypatch):
    monkeypatch.setattr(preload, "_wanted", [])
    preload.want("matplotlib.pyplot", "scipy.optimize")
    preload.want("scipy.spatial", "colorsys", first=True)
    assert preload._wanted == ["scipy.spatial", "colorsys", "matplotlib.pyplot", "scipy.optimize"]
    preload.want("scipy.optimize", first=True)    # named again: moved ahead, not repeated
    assert preload._wanted == ["scipy.optimize", "scipy.spatial", "colorsys", "matplotlib.pyplot"]
    preload.want("colorsys")                       # without first: stays where it is
    assert preload._wanted[2] == "colorsys" and len(preload._wanted) == 4


def test_scipy_spatial_loads_first_while_the_body_fields_are_built():
    """The grading's modules name scipy.spatial for the preload and import it only where
    it is used (the level scaling is its first user, right after the body fields)."""
    import subprocess
    code = ("import sys, seamfit.opt.grade, seamfit.opt.prepare, seamfit.opt.sleeves\n"
            "from seamfit import preload\n"
            "print('scipy.spatial' in sys.modules, preload._wanted[0])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "scipy.spatial"]
