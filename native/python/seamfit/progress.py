"""Progress of a grading that tells the truth: named stages, a fraction of the whole job
that never goes backwards, the time elapsed and an estimate of the time left.

``seamfit.opt.grade.grade`` reports through ``progress(info)`` dicts (``stage``; during
the search ``iteration``, ``exact``, ``objective``; inside simulations ``sim_iteration``
and ``residual``). ``GradeProgress.observe(info)`` turns each into a ``Snapshot``; it only
observes, so a caller's callback still decides about cancelling (returning False). The
command line draws snapshots with ``ConsoleProgress``, the Blender add-on with its job's
progress bar.

How the numbers are made
------------------------
The fraction is time-based: elapsed / (elapsed + time left). Time left is the rest of the
current stage plus the predicted seconds of the stages still to come.

* Predictions (``plan_grading``) come from a simple model measured on the sample pencil
  skirt (size 6 to 10, CPU, 2 cores; see ``_MODEL``): each stage costs
  ``a * (n / 1000) ** p`` seconds for a mesh of n vertices (the body fields scale with
  the number of grid nodes instead), and the search costs N outer iterations at
  ``t_iteration`` each plus one exact checkpoint every M iterations at ``t_checkpoint``,
  so its share grows with the iteration budget and with the mesh. On the GPU the
  simulations and the search are scaled by what an H100 host measured.
* Measurements replace predictions as soon as there are any: a finished stage counts
  with its real duration, a stage that overruns its prediction pushes the later ones up
  by the same factor, a drape's remaining time follows its residual's fall towards the
  tolerance (log scale), and the search's remaining time follows its own measured time
  per outer iteration and per checkpoint.
* A backtrack sends the search's iteration back and a restart may raise the estimate:
  the time left may grow, the fraction then waits; it never goes backwards.
* A search that converges before its budget ends sooner than estimated (the fraction
  jumps forward).
"""
from __future__ import annotations

import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

__all__ = ["DRAPE_STAGES", "STAGES", "ConsoleProgress", "GradeProgress", "Plan", "Snapshot", "estimate_vertices",
           "for_drape", "for_grading", "format_seconds", "plan_grading", "status_text"]

# The stages of a grading, in order, as they are named to the user.
# "coarse grading" only where a fine mesh is graded coarse-to-fine (seamfit.opt.coarse_start).
STAGES = ("coarse grading", "meshing", "body fields", "base drape", "transfer", "level scaling", "initial drapes",
          "optimizing", "refit", "writing")

# The stages of ``seamfit drape``.
DRAPE_STAGES = ("meshing", "body fields", "drape", "writing")

# seamfit.opt's stage names (the ``stage`` of progress events and of the simulations
# inside them) to the stages above. Unknown names are shown as they are and their time
# counts towards the stage in progress.
EVENT_STAGES = {
    "coarse grading": "coarse grading", "mesh": "meshing", "sdf": "body fields", "base drape": "base drape",
    "transfer": "transfer",
    "level scaling": "level scaling", "base pattern on target": "initial drapes",
    "level-scaled start": "initial drapes", "initialize": "initial drapes", "initial drape": "initial drapes",
    "optimize": "optimizing", "checkpoint": "optimizing", "fixed point": "optimizing",
    "refit": "refit", "writing": "writing", "drape": "drape",
}

# Seconds of each stage on the CPU: a * (n / 1000) ** p, n the mesh's vertices; the
# search's outer iteration (at S = 8) and exact checkpoint likewise. Measured with the
# sample pencil skirt graded from size 6 to size 10 at 3, 2 and 1.5 cm edges (866, 1.7K
# and 3K vertices: 0.04, 0.16 and 0.47 s per outer iteration, about 1, 6 and 13 s per
# checkpoint) on a 2-core machine running other work too, fresh caches; the transfer's
# exponent from a 30K-vertex skirt's 15.6 s on a 16-core host. The level scaling depends
# on the bodies, not the mesh (7 to 24 s here). "body fields" is seconds per million grid
# nodes of the two fields (about 0.35 M nodes each at 5 mm; 2.9 s at 5 mm, 16 to 20 s at
# 2.5 mm).
_MODEL = {
    "meshing": (0.15, 1.0),
    "base drape": (2.2, 1.6),
    "transfer": (0.2, 1.3),
    "level scaling": (10.0, 0.0),
    "initial drapes": (3.0, 1.9),
    "refit": (0.7, 0.5),
    "writing": (0.1, 0.5),
    "t_iteration": (0.053, 2.0),
    "t_checkpoint": (1.2, 2.0),
}
_FIELD_SECONDS_PER_MNODE = 4.0
_FIELD_NODES_AT_5MM = 0.35e6
# On the GPU, from a 16-core H100 host: the default skirt (3K vertices) graded in 2.4 s of
# precompute and 4.1 s for 256 outer iterations (16 ms each, checkpoints included),
# against about 200 s for that loop on the 2-core CPU above. Rough: measured rates take
# over within the run.
_GPU_SPEEDUP = {"base drape": 10.0, "initial drapes": 10.0, "t_iteration": 30.0, "t_checkpoint": 30.0}


def estimate_vertices(pattern, edge_length_cm: float) -> int:
    """The sewn mesh's vertex count before it is built: the panels' area over the area of
    an equilateral triangle at that edge, two triangles per vertex, plus 15 % for the
    boundary's smaller triangles (within about 30 % on the sample patterns)."""
    area = sum(abs(p.signed_area_cm2()) for p in getattr(pattern, "panels", []))
    h = max(float(edge_length_cm), 1e-3)
    return max(int(1.15 * area / (math.sqrt(3) / 4 * h * h) / 2), 10)


def _writing(n: int, pictures: int) -> float:
    """The command line's files, and each picture at about a second (matplotlib)."""
    return _cost("writing", n, "cpu") + 1.0 * pictures


def _cost(name: str, n: int, device: str) -> float:
    a, p = _MODEL[name]
    t = a * (max(n, 1) / 1000.0) ** p
    return t / _GPU_SPEEDUP.get(name, 1.0) if device == "cuda" else t


# The share of the search's checkpoints that backtrack (redo their M iterations): 5 of the
# 9 checkpoints in the measurements above. Within a run it moves towards the run's own rate.
BACKTRACK_RATE = 0.4


def search_seconds(iterations: int, every: int, checkpoints: int, t_iteration: float, t_checkpoint: float,
                   backtrack_rate: float) -> float:
    """Seconds of a search with ``iterations`` outer iterations and ``checkpoints`` exact
    checkpoints still to go, each checkpoint's stretch redone as often as backtracks are
    expected (geometric: rate / (1 - rate) times)."""
    rate = min(max(backtrack_rate, 0.0), 0.75)
    redo = rate / (1 - rate) * checkpoints * (min(every, max(iterations, 1)) * t_iteration + t_checkpoint)
    return iterations * t_iteration + checkpoints * t_checkpoint + redo


@dataclass
class Plan:
    """Predicted seconds of each stage and of the search's pieces."""
    seconds: dict                      # stage -> predicted seconds (the search's from the pieces below)
    iterations: int = 0                # N: the outer iteration budget
    checkpoint_every: int = 32         # M (1: every iteration is an exact drape, as the fixed point's)
    t_iteration: float = 0.0
    t_checkpoint: float = 0.0
    time_budget_s: float = 0.0
    tolerance: float = 1e-3            # of the exact drapes: their residual falls towards it
    backtrack_rate: float = BACKTRACK_RATE
    order: tuple = STAGES
    residual_stages: tuple = ("base drape",)    # stages that are one drape (their residual tells)

    def checkpoints(self) -> int:
        if self.iterations <= 0:
            return 0
        return -(-self.iterations // self.checkpoint_every)

    def search_seconds(self) -> float:
        return search_seconds(self.iterations, self.checkpoint_every, self.checkpoints(), self.t_iteration,
                              self.t_checkpoint, self.backtrack_rate)

    def shares(self) -> dict:
        """Each stage's predicted share of the whole job."""
        total = sum(self.seconds.values()) or 1.0
        return {s: t / total for s, t in self.seconds.items()}


def plan_grading(settings=None, n_vertices: int | None = None, *, pattern=None, device: str | None = None,
                 tolerance: float = 1e-3, writing: bool = False, pictures: int = 0) -> Plan:
    """The predicted stages of ``seamfit.opt.grade.grade`` with ``settings`` (GradeSettings)
    on a mesh of ``n_vertices`` (or as estimated from ``pattern``). ``writing``: the
    command line's own last stage (its files and ``pictures`` pictures)."""
    if settings is None:
        from .opt.grade import GradeSettings
        settings = GradeSettings()
    if n_vertices is None:
        n_vertices = estimate_vertices(pattern, settings.edge_length_cm) if pattern is not None else 3000
    n = int(n_vertices)
    coarse_seconds = 0.0
    from .opt.coarse_start import coarse_edge_for, coarse_settings, fine_settings
    coarse_edge = coarse_edge_for(settings)
    if coarse_edge:
        # Coarse-to-fine (seamfit.opt.coarse_start): the whole grading at the coarse edge,
        # then this mesh's stages with its short search.
        scale = (float(settings.edge_length_cm) / coarse_edge) ** 2
        coarse_seconds = sum(plan_grading(coarse_settings(settings), max(int(n * scale), 10), device=device,
                                          tolerance=tolerance).seconds.values())
        settings = fine_settings(settings)
    dev = device or settings.device
    dev = "cuda" if dev == "cuda" else "cpu"
    spacing = max(float(settings.sdf_spacing), 1e-4)
    nodes = 2 * _FIELD_NODES_AT_5MM * (0.005 / spacing) ** 3
    seconds = {**({"coarse grading": coarse_seconds} if coarse_seconds else {}), "meshing": _cost("meshing", n, dev),
               "body fields": _FIELD_SECONDS_PER_MNODE * nodes / 1e6,
               "base drape": _cost("base drape", n, dev), "transfer": _cost("transfer", n, dev),
               "initial drapes": _cost("initial drapes", n, dev)}
    if not settings.drapes_base_pattern:
        # The model holds the unchanged pattern's drape on the target too, which only the
        # report asks for: 1.4 of the 4.8 s of a 60K-triangle grading's initial drapes.
        seconds["initial drapes"] *= 1.0 - 1.4 / 4.8
    if coarse_edge:
        # The start is the coarse level's pattern carried over (no level scaling, no Section 7
        # initialization: one drape of the start); with no search here, so is the base drape.
        seconds["initial drapes"] *= 1.4 / 4.8
        if settings.max_outer_iterations == 0:
            seconds["base drape"] = 0.0
    elif settings.start == "level":
        seconds["level scaling"] = _cost("level scaling", n, "cpu")
    method = settings.method
    iterations = int(settings.max_outer_iterations)
    every = 1 if method == "fixed-point" else max(int(settings.checkpoint_every), 1)
    t_it = 0.0 if method == "fixed-point" else _cost("t_iteration", n, dev)
    # The model's outer iterations were measured at S = 8 simulation iterations each; half
    # of their time is taken to scale with S (the rest is the gradient).
    t_it *= max(settings.inner_iterations, 1) / 8 * 0.5 + 0.5
    plan = Plan(seconds=seconds, iterations=iterations, checkpoint_every=every, t_iteration=t_it,
                order=STAGES if coarse_edge else STAGES[1:],
                t_checkpoint=_cost("t_checkpoint", n, dev),
                time_budget_s=float(settings.time_budget_s), tolerance=float(tolerance),
                # the fixed point has no backtracking: each iteration is one drape
                backtrack_rate=0.0 if method == "fixed-point" else BACKTRACK_RATE)
    seconds["optimizing"] = plan.search_seconds()
    if plan.time_budget_s > 0:
        seconds["optimizing"] = min(seconds["optimizing"], plan.time_budget_s)
    seconds["refit"] = _cost("refit", n, dev)
    if writing:
        seconds["writing"] = _writing(n, pictures)
    return plan


@dataclass(frozen=True)
class Snapshot:
    """Where a job stands."""
    stage: str                 # the stage's name (STAGES, or an unknown event's own name)
    fraction: float            # of the whole job, in [0, 1]; never lower than the previous one
    elapsed: float             # seconds since the job started
    eta: float                 # seconds left, estimated (finite, >= 0)
    detail: str = ""           # e.g. "outer 96/256, objective 0.0123"
    index: int = 0             # the stage's place in the plan (1-based), 0 if unknown
    count: int = 0             # how many stages the plan has
    objective: Optional[float] = None
    iteration: Optional[int] = None


def format_seconds(s: float) -> str:
    """1:05 or 12.3s, as a person reads a clock."""
    if not math.isfinite(s):
        return "?"
    if s < 60:
        return f"{s:.0f}s" if s >= 10 else f"{s:.1f}s"
    m, sec = divmod(int(round(s)), 60)
    if m < 60:
        return f"{m}:{sec:02d}"
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{sec:02d}"


class GradeProgress:
    """Follows one job's progress events (see the module's docstring)."""

    def __init__(self, plan: Plan, clock: Callable[[], float] = time.perf_counter):
        self.plan = plan
        self.clock = clock
        self.order = [s for s in plan.order if s in plan.seconds]
        self.t0 = clock()
        self.current = -1                  # index into self.order; -1 before the first event
        self.stage_start = self.t0
        self.label = "starting"
        self.actual: dict[str, float] = {}
        self.fraction = 0.0
        self.finished = False
        self._p = 0.0                      # the current stage's own progress, from its residuals
        self._r0: Optional[float] = None
        self._sim_stage: Optional[str] = None
        self._sim: Optional[tuple] = None          # the last simulation iteration and residual
        self.iteration: Optional[int] = None
        self.objective: Optional[float] = None
        # The search: when it started, its last event, and the measured pieces.
        self._loop_last: Optional[float] = None
        self._it_times: list[float] = []
        self._ck_times: list[float] = []
        self._checkpoints = self._backtracks = 0

    # -- events ---------------------------------------------------------------
    def observe(self, info: dict) -> Snapshot:
        """Take one progress event; the snapshot after it."""
        now = self.clock()
        raw = str(info.get("stage", ""))
        stage = EVENT_STAGES.get(raw) or ("optimizing" if "optimi" in raw else None)
        if stage is not None:
            self._enter(stage, now)
        self.label = stage or raw or self.label
        if "sim_iteration" in info:
            self._residual(raw, info.get("residual"), info.get("sim_iteration"))
        elif stage == "optimizing" and info.get("iteration") is not None:
            self._search(info, now)
        return self.snapshot(now)

    def enter(self, stage: str) -> Snapshot:
        """A stage of the caller's own (the command line's "writing")."""
        return self.observe({"stage": stage})

    def finish(self) -> Snapshot:
        """The job is done: fraction 1, nothing left."""
        now = self.clock()
        if not self.finished:
            self._close(now)
            self.finished = True
            self.fraction = 1.0
        return self.snapshot(now)

    def seconds_by_stage(self) -> dict:
        """Measured seconds of each stage reached so far (the current one until now)."""
        out = dict(self.actual)
        if 0 <= self.current < len(self.order) and not self.finished:
            s = self.order[self.current]
            out[s] = out.get(s, 0.0) + self.clock() - self.stage_start
        return out

    # -- internals ------------------------------------------------------------
    def _enter(self, stage: str, now: float) -> None:
        if stage not in self.order:
            return
        i = self.order.index(stage)
        if i <= self.current:
            return      # a later piece of an earlier stage (the target's field after the transfer)
        first = self.current < 0
        self._close(now)
        for skipped in self.order[self.current + 1:i]:
            self.actual.setdefault(skipped, 0.0)
        # The checks before the first event count towards the first stage.
        self.current, self.stage_start = i, (self.t0 if first else now)
        self._p, self._r0, self._sim_stage = 0.0, None, None

    def _close(self, now: float) -> None:
        if 0 <= self.current < len(self.order):
            s = self.order[self.current]
            self.actual[s] = self.actual.get(s, 0.0) + now - self.stage_start
            self.stage_start = now

    def _residual(self, raw: str, r, it=None) -> None:
        """A drape's progress: how far its residual fell from its first value towards the
        tolerance, on a log scale (only for a stage that is one drape: the base drape)."""
        self._sim = (it, r) if it is not None and r is not None else None
        if raw != self._sim_stage:
            self._sim_stage, self._r0 = raw, None
        if raw not in self.plan.residual_stages or r is None:
            return
        r = float(r)
        tol = self.plan.tolerance
        if not (r > 0 and math.isfinite(r)):
            return
        if self._r0 is None:
            self._r0 = max(r, tol * 1.0001)
        done = math.log(self._r0 / max(r, tol)) / math.log(self._r0 / tol)
        self._p = max(self._p, min(max(done, 0.0), 1.0))

    def _search(self, info: dict, now: float) -> None:
        k = int(info["iteration"])
        self.iteration = k
        if info.get("objective") is not None:
            self.objective = float(info["objective"])
        last = self._loop_last if self._loop_last is not None else self.stage_start
        dt = max(now - last, 0.0)
        if info.get("exact"):
            # A checkpoint's interval holds its outer iteration too.
            self._ck_times.append(max(dt - self._t_iteration(), 0.0))
            self._checkpoints += 1
            self._backtracks += bool(info.get("backtrack"))
        elif self._loop_last is not None:
            self._it_times.append(dt)
        self._loop_last = now

    def _t_iteration(self) -> float:
        if self._it_times:
            recent = self._it_times[-64:]
            return sum(recent) / len(recent)
        return self.plan.t_iteration * self._factor()

    def _t_checkpoint(self) -> float:
        if self._ck_times:
            recent = self._ck_times[-4:]
            return sum(recent) / len(recent)
        return self.plan.t_checkpoint * self._factor()

    def _factor(self, now: float | None = None) -> float:
        """How much slower (> 1) or faster than the model this machine runs, from the
        stages finished so far; stages much faster than predicted (a cached base drape) say
        nothing about the machine and are left out."""
        done_t = done_p = 0.0
        for s, t in self.actual.items():
            p = self.plan.seconds.get(s, 0.0)
            if p > 0.05 and t >= 0.25 * p:
                done_t, done_p = done_t + t, done_p + p
        if done_p <= 0:
            return 1.0
        return min(max(done_t / done_p, 0.2), 5.0)

    def _search_left(self, now: float, factor: float) -> float:
        plan = self.plan
        k = self.iteration or 0
        n, m = plan.iterations, plan.checkpoint_every
        t_it, t_ck = self._t_iteration(), self._t_checkpoint()
        checkpoints_left = max(-(-n // m) - k // m, 0) if n > 0 else 0
        # The run's own backtracks count as much as two checkpoints' worth of the prior.
        rate = (self._backtracks + 2 * plan.backtrack_rate) / (self._checkpoints + 2)
        left = search_seconds(max(n - k, 0), m, checkpoints_left, t_it, t_ck, rate)
        # The piece under way (an outer iteration, with an exact drape where a checkpoint
        # is due) is partly done; one that overran is taken to be a quarter further on.
        since = now - (self._loop_last if self._loop_last is not None else self.stage_start)
        expected = t_it + (t_ck if (k + 1) % m == 0 or k + 1 >= n else 0.0)
        left += max(expected - since, 0.25 * since) - expected
        if plan.time_budget_s > 0:
            budget_left = plan.time_budget_s - (now - self.t0) + self._t_checkpoint()
            left = min(left, max(budget_left, 0.0))
        return max(left, 0.02 * (now - self.stage_start))

    def _stage_left(self, stage: str, now: float, factor: float) -> float:
        t = now - self.stage_start
        if stage == "optimizing":
            return self._search_left(now, factor)
        pred = self.plan.seconds.get(stage, 0.0) * factor
        p = self._p
        if p > 0:
            # Towards the rate measured in this stage as its own progress grows.
            w = min(1.0, p / 0.3)
            total = (1 - w) * pred + w * t / p
            return max(total - t, 0.0)
        # Past its prediction: assume it is a quarter further on than its time so far.
        return max(pred - t, 0.25 * t)

    def time_left(self, now: float | None = None) -> float:
        now = self.clock() if now is None else now
        if self.finished:
            return 0.0
        factor = self._factor(now)
        if self.current < 0:
            return sum(self.plan.seconds.values())
        stage = self.order[self.current]
        left = self._stage_left(stage, now, factor)
        pred = self.plan.seconds.get(stage, 0.0)
        t = now - self.stage_start
        if stage != "optimizing" and pred > 0.05 and t > pred * factor:
            factor = min(max(factor, t / pred), 5.0)   # an overrun says the machine is slower
        for s in self.order[self.current + 1:]:
            left += self.plan.seconds[s] * factor
        return max(left, 0.0)

    def snapshot(self, now: float | None = None) -> Snapshot:
        now = self.clock() if now is None else now
        elapsed = max(now - self.t0, 0.0)
        eta = self.time_left(now)
        if not self.finished:
            f = elapsed / (elapsed + eta) if elapsed + eta > 0 else 0.0
            self.fraction = max(self.fraction, min(f, 0.99))
        detail = ""
        if self._sim_stage in self.plan.residual_stages and self.label == self._sim_stage and self._sim is not None:
            detail = f"iteration {self._sim[0]}, relative residual {self._sim[1]:.3e}"
        if self.label == "optimizing" and self.iteration is not None:
            detail = f"outer {self.iteration}/{self.plan.iterations}"
            if self.objective is not None:
                detail += f", objective {self.objective:.6g}"
        index = self.order.index(self.label) + 1 if self.label in self.order and not self.finished else 0
        snap = Snapshot(stage="done" if self.finished else self.label, fraction=self.fraction, elapsed=elapsed,
                        eta=float(eta) if math.isfinite(eta) else 0.0, detail=detail, index=index,
                        count=len(self.order), objective=self.objective, iteration=self.iteration)
        return snap


def for_grading(pattern, settings, *, device: str | None = None, tolerance: float = 1e-3,
                writing: bool = False, pictures: int = 0,
                clock: Callable[[], float] = time.perf_counter) -> GradeProgress:
    """A tracker for ``grade(pattern, ..., settings)``, its mesh size estimated from the
    pattern."""
    return GradeProgress(plan_grading(settings, pattern=pattern, device=device, tolerance=tolerance,
                                      writing=writing, pictures=pictures), clock=clock)


def for_drape(pattern, edge_length_cm: float, sdf_spacing: float, *, device: str = "cpu", tolerance: float = 1e-3,
              pictures: int = 1, clock: Callable[[], float] = time.perf_counter) -> GradeProgress:
    """A tracker for ``seamfit drape``: meshing, the body's field, the drape (followed by its
    residual), writing; the same model as a grading's base drape."""
    n = estimate_vertices(pattern, edge_length_cm)
    dev = "cuda" if device == "cuda" else "cpu"
    nodes = _FIELD_NODES_AT_5MM * (0.005 / max(float(sdf_spacing), 1e-4)) ** 3
    seconds = {"meshing": _cost("meshing", n, dev), "body fields": _FIELD_SECONDS_PER_MNODE * nodes / 1e6,
               "drape": _cost("base drape", n, dev), "writing": _writing(n, pictures)}
    plan = Plan(seconds=seconds, tolerance=float(tolerance), order=DRAPE_STAGES, residual_stages=("drape",))
    return GradeProgress(plan, clock=clock)


def status_text(snap: Snapshot) -> str:
    """One line for a status bar: "optimizing (7/9) 42% - 0:41, about 1:02 left - outer 96/256"."""
    where = f"{snap.stage} ({snap.index}/{snap.count})" if snap.index else snap.stage
    text = f"{where} {100 * snap.fraction:.0f}% - {format_seconds(snap.elapsed)}"
    if snap.stage != "done":
        text += f", about {format_seconds(snap.eta)} left"
    if snap.detail:      # last: what a narrow terminal cuts off
        text += f" - {snap.detail}"
    return text


@dataclass
class ConsoleProgress:
    """Draws a tracker's snapshots on a stream (stderr): a bar redrawn in place on a
    terminal, plain lines elsewhere (a log file, a pipe), one per stage, per checkpoint and
    per event marked ``log``. As a progress callback it returns None: the command line does not cancel."""
    tracker: GradeProgress
    stream: object = field(default_factory=lambda: sys.stderr)
    tty: Optional[bool] = None
    width: int = 24
    interval: float = 0.1              # a bar is redrawn at most this often
    _drawn: float = field(default=-1e9, init=False)
    _line: int = field(default=0, init=False)       # the bar's length on screen (0: none shown)
    _stage: str = field(default="", init=False)

    def __post_init__(self):
        if self.tty is None:
            isatty = getattr(self.stream, "isatty", None)
            try:
                self.tty = bool(isatty and isatty())
            except (ValueError, OSError):
                self.tty = False
        if self.tty and self.stream is sys.stderr:
            # Warnings written to stderr while the bar is up (a discarded cache entry, a
            # picture not drawn) clear it first instead of running on after it.
            sys.stderr = _ClearingStream(self, self.stream)

    def __call__(self, info: dict):
        snap = self.tracker.observe(info)
        self._show(snap, info)
        return None

    def enter(self, stage: str) -> None:
        self._show(self.tracker.enter(stage), {"stage": stage})

    def print(self, message: str) -> None:
        """A line of its own (a note, a warning) while the bar is up: the bar is cleared,
        the line written and the bar drawn again below it."""
        if self.tty and self._line:
            self._clear()
            self._write(message + "\n")
            self._bar(self.tracker.snapshot())
        else:
            self._write(message + "\n")

    def close(self) -> None:
        """The job is over (done or failed): the bar gives way to the next lines."""
        snap = self.tracker.finish() if not self.tracker.finished else self.tracker.snapshot()
        if self.tty:
            if self._line:
                self._bar(snap)
                self._write("\n")
                self._line = 0
        elif self._stage != "done":
            self._write(self._plain(snap) + "\n")
        self._stage = "done"
        self._release()

    def fail(self) -> None:
        """The job stopped with an error: end the bar's line, claim nothing."""
        if self.tty and self._line:
            self._write("\n")
            self._line = 0
        self._stage = "done"
        self._release()

    def _release(self) -> None:
        if isinstance(sys.stderr, _ClearingStream) and sys.stderr.console is self:
            sys.stderr = sys.stderr.stream

    def _clear(self) -> None:
        if self._line:
            self._write("\r" + " " * self._line + "\r")
            self._line = 0
            self._drawn = -1e9      # drawn again at the next event

    def stages_line(self) -> str:
        """Where the time went, stage by stage."""
        parts = [f"{s} {t:.1f} s" for s, t in self.tracker.seconds_by_stage().items() if t >= 0.05]
        return "time by stage: " + ", ".join(parts)

    # -- drawing --------------------------------------------------------------
    def _show(self, snap: Snapshot, info: dict) -> None:
        if self.tty:
            now = time.monotonic()
            if snap.stage != self._stage or info.get("exact") or now - self._drawn >= self.interval:
                self._bar(snap)
                self._drawn = now
        elif snap.stage != self._stage or (snap.stage == "optimizing" and info.get("exact")) or info.get("log"):
            line = self._plain(snap)
            if info.get("exact"):
                line += "  (backtrack)" if info.get("backtrack") else "  (checkpoint)"
            self._write(line + "\n")
        self._stage = snap.stage

    def _plain(self, snap: Snapshot) -> str:
        where = f"{snap.stage} ({snap.index}/{snap.count})" if snap.index else snap.stage
        line = f"[{snap.elapsed:7.1f}s] {100 * snap.fraction:3.0f}%  {where}"
        if snap.detail:
            line += f"  {snap.detail}"
        if snap.stage != "done":
            line += f"  about {format_seconds(snap.eta)} left"
        return line

    def _bar(self, snap: Snapshot) -> None:
        filled = int(round(self.width * snap.fraction))
        # No wider than the terminal: a wrapped line could not be redrawn in place.
        columns = shutil.get_terminal_size((100, 24)).columns
        text = f"\r[{'#' * filled}{'.' * (self.width - filled)}] {status_text(snap)}"[:max(columns, 20)]
        pad = max(self._line - len(text), 0)
        self._write(text + " " * pad)
        self._line = len(text)

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (ValueError, OSError):
            pass        # a closed stream must not stop the job


class _ClearingStream:
    """Stands in for sys.stderr while a bar is up: anything else written there first clears
    the bar's line."""

    def __init__(self, console: ConsoleProgress, stream):
        self.console = console
        self.stream = stream

    def write(self, text: str):
        if text:
            self.console._clear()
        return self.stream.write(text)

    def __getattr__(self, name):
        return getattr(self.stream, name)
