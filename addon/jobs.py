# SPDX-License-Identifier: GPL-3.0-or-later
"""Long computations in a worker thread.

A job runs a pure-Python function (no bpy access: Blender's data is not thread safe)
on inputs captured on the main thread. The main thread polls the job from a modal
operator's timer, shows its progress, and applies the result to the scene only once
the job has finished; a cancelled or failed job therefore never touches the scene.
"""
from __future__ import annotations

import math
import threading
import time
import traceback
from typing import Any, Callable

# The one job that runs at a time; panels read it to draw progress.
_active: "Job | None" = None
_lock = threading.Lock()


class Cancelled(Exception):
    """Raised inside the worker when the user cancelled the job."""


class Job:
    """Progress, cancellation and outcome of one computation.

    ``fn(job)`` runs in the worker; it reports through ``job.update(...)`` and
    calls ``job.check()`` (or uses ``job.callback``) so that a cancel request stops it.
    """

    def __init__(self, label: str, fn: Callable[["Job"], Any]):
        self.label = label
        self._fn = fn
        self._cancel = threading.Event()
        self._done = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.stage = "waiting"
        self.fraction = 0.0
        self.eta: float | None = None       # seconds left, where the computation estimates it
        self.objective: float | None = None
        self.history: list[tuple[int, float]] = []
        self.result: Any = None
        self.error: BaseException | None = None
        self.error_trace: str | None = None
        self.started = 0.0
        self.finished = 0.0

    # -- worker side --------------------------------------------------------
    def update(self, stage: str | None = None, fraction: float | None = None,
               objective: float | None = None, iteration: int | None = None,
               eta: float | None = None) -> None:
        with self._lock:
            if stage is not None:
                self.stage = stage
            if fraction is not None:
                # Never backwards, whatever the stage reports.
                self.fraction = max(self.fraction, min(max(float(fraction), 0.0), 1.0))
            if eta is not None:
                self.eta = max(float(eta), 0.0) if math.isfinite(eta) else None
            if objective is not None:
                self.objective = float(objective)
                self.history.append((int(iteration if iteration is not None else len(self.history)),
                                     float(objective)))
        self.check()

    def check(self) -> None:
        if self._cancel.is_set():
            raise Cancelled()

    def callback(self, stage: str, max_iterations: int | None = None,
                 span: tuple[float, float] = (0.0, 1.0),
                 target: float | None = None) -> Callable[[int, float], bool]:
        """A ``callback(iteration, value) -> bool`` for seamfit's solvers: it records
        progress within ``span`` of the bar and returns False once cancel was asked.
        Progress is iteration / max_iterations, or, with ``target``, how far the value
        (a residual) has fallen from its first value towards target on a log scale."""
        lo, hi = span
        first: list[float] = []

        def cb(iteration: int, value: float) -> bool:
            frac = None
            if target is not None and value > 0 and math.isfinite(value):
                if not first:
                    first.append(value)
                r0 = max(first[0], target * 1.0001)
                done = math.log(r0 / max(value, target)) / math.log(r0 / target)
                frac = lo + (hi - lo) * min(1.0, max(0.0, done))
            elif max_iterations:
                frac = lo + (hi - lo) * min(1.0, (iteration + 1) / max_iterations)
            with self._lock:
                self.stage = stage
                if frac is not None:
                    self.fraction = max(self.fraction, frac)    # a residual may rise for a while
                self.objective = float(value)
                self.history.append((int(iteration), float(value)))
            return not self._cancel.is_set()
        return cb

    def _run(self) -> None:
        try:
            self.result = self._fn(self)
            # A solver may stop early on its own when the callback returns False.
            self.check()
        except Cancelled:
            self.result = None
        except BaseException as exc:  # reported on the main thread
            self.error = exc
            self.error_trace = traceback.format_exc()
        finally:
            self.finished = time.monotonic()
            self._done.set()

    # -- main thread side ----------------------------------------------------
    def start(self) -> "Job":
        self.started = time.monotonic()
        self._thread = threading.Thread(target=self._run, name=f"seamfit {self.label}", daemon=True)
        self._thread.start()
        return self

    def run_here(self) -> "Job":
        """Run in the calling thread (scripts, batch runs, tests of the synchronous path)."""
        self.started = time.monotonic()
        self._run()
        return self

    def cancel(self) -> None:
        self._cancel.set()

    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        return self._done.wait(timeout)

    def elapsed(self) -> float:
        end = self.finished if self.done else time.monotonic()
        return end - self.started if self.started else 0.0

    def snapshot(self) -> dict:
        with self._lock:
            return {"label": self.label, "stage": self.stage, "fraction": self.fraction, "eta": self.eta,
                    "objective": self.objective, "iterations": len(self.history),
                    "elapsed": self.elapsed(), "cancelled": self.cancelled}


def _clock(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.0f} s"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m}:{s:02d}" if m < 60 else f"{m // 60}:{m % 60:02d}:{s:02d}"


def progress_text(snap: dict) -> str:
    """"optimizing 42%, about 1:02 left" for the progress bar and the status bar."""
    text = f"{snap['stage']} {100 * snap['fraction']:.0f}%"
    eta = snap.get("eta")
    if eta is not None and snap["fraction"] < 1.0:
        text += f", about {_clock(eta)} left"
    return text


def active() -> Job | None:
    return _active


def begin(job: Job) -> Job:
    """Start ``job`` as the active one; refuse while another is running."""
    global _active
    with _lock:
        if _active is not None and not _active.done:
            raise RuntimeError(f"seamfit is busy with {_active.label}; wait or press Esc to cancel it")
        _active = job
    return job.start()


def end(job: Job) -> None:
    global _active
    with _lock:
        if _active is job:
            _active = None


def cancel_all(timeout: float = 5.0) -> None:
    """Ask the active job to stop and wait a little for it (used when the add-on is disabled)."""
    job = _active
    if job is not None:
        job.cancel()
        job.wait(timeout)
        end(job)
