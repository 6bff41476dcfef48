"""Background imports during the body fields (seamfit.preload): the wanted modules are
imported on another thread, once; one that cannot be imported costs nothing there."""
from __future__ import annotations

import sys

from seamfit import preload
from common import SAMPLES


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
    preload has something to do; the grading still refits (tests/opt/test_grade.py)."""
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


def test_a_wanted_call_runs_on_the_thread_once(monkeypatch):
    monkeypatch.setattr(preload, "_wanted", [])
    monkeypatch.setattr(preload, "_thread", None)
    calls = []

    def fails():
        calls.append("fails")
        raise RuntimeError("left to fail where it is needed")

    preload.want(lambda: calls.append("first"), first=True)
    preload.want(fails)
    preload.start()
    preload._thread.join(timeout=30)
    assert calls == ["first", "fails"]
    assert preload._wanted == []                  # done: the next start calls nothing
    preload.start()
    if preload._thread is not None:
        preload._thread.join(timeout=30)
    assert calls == ["first", "fails"]


def test_a_body_measured_ahead_is_measured_once(monkeypatch):
    """The level scaling's measurements, taken on the preload's thread while the fields are
    built: a caller that asks while they are being taken waits for them, not measuring twice;
    if that measurement fails the caller measures and gets the error itself."""
    import threading
    import seamfit.body.measure as measure
    from seamfit.body import load_body
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    monkeypatch.setattr(measure, "_memo", type(measure._memo)())
    started, release, count = threading.Event(), threading.Event(), []
    real = measure._measure

    def slow(*a, **k):
        count.append(1)
        started.set()
        release.wait(timeout=30)
        return real(*a, **k)

    monkeypatch.setattr(measure, "_measure", slow)
    ahead = threading.Thread(target=measure.body_measurements, args=(body,))
    ahead.start()
    assert started.wait(timeout=30)
    out = {}
    asker = threading.Thread(target=lambda: out.setdefault("m", measure.body_measurements(body)))
    asker.start()
    asker.join(timeout=0.3)
    assert asker.is_alive()                       # waiting for the measurement in hand
    release.set()
    ahead.join(timeout=60)
    asker.join(timeout=60)
    assert len(count) == 1 and out["m"]["hip"] > 0

    def broken(*a, **k):
        count.append(1)
        raise ValueError("unmeasurable")

    monkeypatch.setattr(measure, "_measure", broken)
    other = type(body)(body.vertices * 1.01, body.faces)
    for _ in range(2):                            # nothing remembered from a failure
        try:
            measure.body_measurements(other)
        except ValueError:
            pass
        else:
            raise AssertionError("the failure is the caller's")
    assert len(count) == 3
