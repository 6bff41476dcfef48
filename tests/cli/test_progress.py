"""Progress that tells the truth (seamfit.progress): named stages, a fraction that never goes
backwards, a finite estimate of the time left, a bar on a terminal and plain lines in a log,
the same in the command line and in the add-on; cancelling still works."""
import importlib
import io
import json
import math
import sys
import types

import pytest

from seamfit.cli import main
from seamfit.errors import SolveError
from seamfit.progress import (BACKTRACK_RATE, STAGES, ConsoleProgress, GradeProgress, estimate_vertices,
                              format_seconds, plan_grading, search_seconds)
from common import REPO, SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
COARSE = dict(edge_length_cm=5.0, sdf_spacing=0.01, max_outer_iterations=4, checkpoint_every=2)


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


@pytest.fixture(scope="module")
def events():
    """A real coarse grading's progress events, each with the time it came."""
    import time
    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings, grade
    from seamfit.pattern import load_pattern
    t0 = time.perf_counter()
    seen = []

    def progress(info):
        seen.append((time.perf_counter() - t0, dict(info)))

    grade(load_pattern(PATTERN), load_body(B0), load_body(B1), GradeSettings(**COARSE), progress=progress)
    return seen, time.perf_counter() - t0


def _replay(events, settings=None):
    from seamfit.opt.grade import GradeSettings
    from seamfit.pattern import load_pattern
    clock = Clock()
    tracker = GradeProgress(plan_grading(settings or GradeSettings(**COARSE), pattern=load_pattern(PATTERN)),
                            clock=clock)
    snaps = []
    for t, info in events:
        clock.t = t
        snaps.append(tracker.observe(info))
    return tracker, snaps, clock


def test_a_real_gradings_progress_is_named_monotone_and_finite(events):
    seen, total = events
    tracker, snaps, clock = _replay(seen)
    fractions = [s.fraction for s in snaps]
    assert all(b >= a for a, b in zip(fractions, fractions[1:]))
    assert all(0.0 <= f < 1.0 for f in fractions)
    assert all(math.isfinite(s.eta) and s.eta >= 0 for s in snaps)
    # every stage of the grading is named, in order
    named = []
    for s in snaps:
        if not named or named[-1] != s.stage:
            named.append(s.stage)
    assert named == ["meshing", "body fields", "base drape", "transfer", "level scaling", "initial drapes",
                     "optimizing", "refit"]
    assert set(named) <= set(STAGES)
    assert any(s.detail.startswith("outer 4/4") for s in snaps)
    clock.t = total
    end = tracker.finish()
    assert end.fraction == 1.0 and end.eta == 0.0 and end.stage == "done"
    # the measured seconds by stage add up to the whole run
    by_stage = tracker.seconds_by_stage()
    assert sum(by_stage.values()) == pytest.approx(total, rel=1e-6)


def test_time_left_follows_the_search_and_fraction_waits_on_a_backtrack():
    """A backtrack sends the iteration back: the time left grows, the fraction does not fall."""
    from seamfit.opt.grade import GradeSettings
    clock = Clock()
    tracker = GradeProgress(plan_grading(GradeSettings(max_outer_iterations=64, checkpoint_every=32),
                                         n_vertices=1000), clock=clock)
    for t, stage in enumerate(["mesh", "sdf", "base drape", "transfer", "initial drape"]):
        clock.t = float(t)
        tracker.observe({"stage": stage})
    clock.t = 10.0
    snaps = []
    for k in range(1, 64):
        clock.t += 2.1 if k == 32 else 0.1     # a checkpoint: an outer iteration and a 2 s drape
        snaps.append(tracker.observe({"stage": "optimize", "iteration": k, "objective": 1.0, "exact": k == 32}))
    clock.t += 2.1
    back = tracker.observe({"stage": "optimize", "iteration": 32, "objective": 2.0, "exact": True, "backtrack": True})
    assert back.eta > snaps[-1].eta and back.fraction >= snaps[-1].fraction
    # 32 iterations at 0.1 s and a checkpoint at 2 s are left, that stretch redone as often as
    # backtracks are expected (1 in 2 so far, against a prior of BACKTRACK_RATE)
    rate = (1 + 2 * BACKTRACK_RATE) / (2 + 2)
    expected = search_seconds(32, 32, 1, 0.1, 2.0, rate) + tracker.plan.seconds["refit"] * tracker._factor()
    assert back.eta == pytest.approx(expected, rel=0.05)
    # while the next piece runs the time left goes down
    clock.t += 0.05
    assert tracker.snapshot().eta < back.eta


def test_the_search_gets_a_larger_share_with_more_iterations_and_a_finer_mesh():
    from seamfit.opt.grade import GradeSettings
    share = lambda n, it: plan_grading(GradeSettings(max_outer_iterations=it), n_vertices=n).shares()["optimizing"]
    assert share(3000, 256) > share(3000, 32) and share(30000, 256) > share(3000, 256) * 0.9
    assert plan_grading(GradeSettings(), n_vertices=3000).seconds["optimizing"] > 0


def test_the_vertex_estimate_is_close():
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    p = load_pattern(PATTERN)
    for h in (3.0, 1.5):
        n = build_sewn_mesh(p, h).n_vertices
        assert 0.6 * n < estimate_vertices(p, h) < 1.5 * n


class _Stream(io.StringIO):
    def __init__(self, tty):
        super().__init__()
        self._tty = tty

    def isatty(self):
        return self._tty


def test_a_bar_on_a_terminal_and_plain_lines_in_a_log(events):
    seen, total = events
    out = {}
    for tty in (True, False):
        clock = Clock()
        from seamfit.opt.grade import GradeSettings
        from seamfit.pattern import load_pattern
        stream = _Stream(tty)
        console = ConsoleProgress(GradeProgress(plan_grading(GradeSettings(**COARSE), pattern=load_pattern(PATTERN),
                                                             writing=True), clock=clock), stream, interval=0.0)
        assert console.tty is tty
        for t, info in seen:
            clock.t = t
            assert console(info) is None        # observes only: never cancels
        console.enter("writing")
        console.close()
        out[tty] = stream.getvalue()
    bar, log = out[True], out[False]
    assert "\r[" in bar and "#" in bar and "left" in bar and bar.endswith("\n") and bar.count("\n") == 1
    assert "\r" not in log
    lines = log.splitlines()
    assert len(lines) >= 8 and all(line.startswith("[") for line in lines)
    for stage in ("meshing", "body fields", "base drape", "transfer", "optimizing", "refit", "writing"):
        assert any(stage in line for line in lines), stage
    assert any("(checkpoint)" in line for line in lines) and "100%  done" in lines[-1]
    assert all("left" in line for line in lines[:-1])
    percents = [int(line.split("]")[1].split("%")[0]) for line in lines]
    assert percents == sorted(percents)


def test_the_command_line_prints_plain_lines_to_a_log(tmp_path, capsys):
    code = main(["grade", str(PATTERN), "--base-body", str(B0), "--target-body", str(B1), "--out",
                 str(tmp_path / "out"), "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "4",
                 "--checkpoint-every", "2", "--no-picture"])
    err = capsys.readouterr().err
    assert code == 0
    assert "\r" not in err
    for stage in ("meshing", "body fields", "base drape", "optimizing", "refit", "writing", "100%  done"):
        assert stage in err, stage
    assert "time by stage: " in err
    assert json.loads((tmp_path / "out" / "report.json").read_text())["outer_iterations"] >= 1


def test_quiet_prints_no_progress(tmp_path, capsys):
    code = main(["grade", str(PATTERN), "--base-body", str(B0), "--target-body", str(B1), "--out",
                 str(tmp_path / "out"), "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "2",
                 "--checkpoint-every", "1", "--no-picture", "-q"])
    assert code == 0 and capsys.readouterr().err == ""


@pytest.mark.parametrize("at", ["transfer", "optimize"])
def test_cancelling_through_a_tracked_callback_still_stops(at):
    """A caller's callback that shows the tracker's snapshot and answers False stops the
    grading with SolveError "cancelled", as without the tracker."""
    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings, grade
    from seamfit.pattern import load_pattern
    pattern = load_pattern(PATTERN)
    settings = GradeSettings(**COARSE)
    tracker = GradeProgress(plan_grading(settings, pattern=pattern))
    stages = []

    def progress(info):
        stages.append(tracker.observe(info).stage)
        return info.get("stage") != at

    with pytest.raises(SolveError, match="cancelled"):
        grade(pattern, load_body(B0), load_body(B1), settings, progress=progress)
    assert "refit" not in stages


def _addon_without_bpy():
    """The add-on's pure-Python modules (jobs, compute), without its bpy-bound __init__."""
    name = "seamfit_addon_pure"
    if name not in sys.modules:
        pkg = types.ModuleType(name)
        pkg.__path__ = [str(REPO / "addon")]
        sys.modules[name] = pkg
    return importlib.import_module(f"{name}.jobs"), importlib.import_module(f"{name}.compute")


def test_the_addons_job_shows_the_same_progress_and_cancels(events):
    jobs, compute = _addon_without_bpy()
    seen, _ = events
    job = jobs.Job("adjust", lambda j: None)
    tracker, _, clock = _replay([])
    cb = compute._grade_progress(job, tracker)
    fractions = []
    for t, info in seen:
        clock.t = t
        assert cb(info) is True
        snap = job.snapshot()
        fractions.append(snap["fraction"])
        assert snap["eta"] is not None and math.isfinite(snap["eta"])
    assert fractions == sorted(fractions) and 0 < fractions[-1] < 1
    assert job.snapshot()["stage"] == "refit" and job.objective is not None
    text = jobs.progress_text(job.snapshot())
    assert text.startswith("refit ") and "% " not in text[:3] and "left" in text
    job.cancel()
    assert cb({"stage": "optimize", "iteration": 1, "objective": 1.0}) is False
    # a stage that reports a lower fraction does not move the bar back
    job2 = jobs.Job("x", lambda j: None)
    job2.update(fraction=0.5)
    job2.update(fraction=0.2)
    assert job2.snapshot()["fraction"] == 0.5


def test_clock_format():
    assert format_seconds(5.25) == "5.2s" and format_seconds(42) == "42s"
    assert format_seconds(65) == "1:05" and format_seconds(3725) == "1:02:05"


@pytest.mark.parametrize("tty", [True, False])
def test_drape_shows_the_same_progress(tmp_path, monkeypatch, tty):
    """seamfit drape: meshing, body fields, drape (iteration and residual), writing; a bar on a
    terminal, plain lines in a log; its notes on lines of their own."""
    stream = _Stream(tty)
    monkeypatch.setattr(sys, "stderr", stream)
    code = main(["drape", str(PATTERN), str(B0), "--out", str(tmp_path / "d"), "--edge-length", "5",
                 "--sdf-spacing", "0.01", "--max-iterations", "2000", "--no-picture", "--no-coarse-start"])
    err = stream.getvalue()
    assert code == 0
    for stage in ("meshing (1/4)", "body fields (2/4)", "drape (3/4)", "writing (4/4)", "iteration"):
        assert stage in err, stage
    assert ("\r[" in err) is tty
    lines = err.replace("\r", "\n").splitlines()
    assert any(line.startswith("mesh: ") for line in lines) and any(line.startswith("body SDF: ") for line in lines)
    assert any(line.startswith(("converged", "NOT converged")) for line in lines)
    if not tty:
        percents = [int(line.split("]")[1].split("%")[0]) for line in lines if line.startswith("[")]
        assert percents == sorted(percents) and percents[-1] == 100


def test_the_addons_drape_job_shows_stages_and_time_left_and_cancels():
    from seamfit.pattern import load_pattern
    from seamfit.progress import for_drape
    jobs, compute = _addon_without_bpy()
    job = jobs.Job("drape", lambda j: None)
    clock = Clock()
    stage, callback = compute._drape_progress(job, for_drape(load_pattern(PATTERN), 3.0, 0.005, clock=clock))
    seen = []
    for name in ("meshing", "body fields", "drape"):
        clock.t += 0.5
        stage(name)
        seen.append(job.snapshot())
    for it, res in enumerate([1e3, 10.0, 1.0, 0.1, 0.01]):
        clock.t += 0.5
        assert callback(100 * it, res) is True
        seen.append(job.snapshot())
    assert [s["stage"] for s in seen[:3]] == ["meshing", "body fields", "drape"]
    fractions = [s["fraction"] for s in seen]
    assert fractions == sorted(fractions) and all(s["eta"] is not None and math.isfinite(s["eta"]) for s in seen)
    assert job.objective == 0.01 and len(job.history) == 5
    job.cancel()
    assert callback(600, 0.005) is False


def test_other_writers_to_stderr_clear_the_bar_first(monkeypatch):
    from seamfit.opt.grade import GradeSettings
    stream = _Stream(True)
    monkeypatch.setattr(sys, "stderr", stream)
    console = ConsoleProgress(GradeProgress(plan_grading(GradeSettings(), n_vertices=1000), clock=Clock()))
    console({"stage": "mesh"})
    assert stream.getvalue().startswith("\r[") and sys.stderr is not stream
    print("seamfit: warning: something", file=sys.stderr)
    head, warning = stream.getvalue().rsplit("\r", 1)
    assert warning == "seamfit: warning: something\n" and head.endswith(" ")
    console({"stage": "sdf"})
    console.close()
    assert sys.stderr is stream and stream.getvalue().endswith("\n")
