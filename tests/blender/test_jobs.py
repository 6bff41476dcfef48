# SPDX-License-Identifier: GPL-3.0-or-later
"""The worker-thread job machinery: progress, live objective, cancel, errors, one at a time."""
import threading
import time

import pytest

from helpers import addon


def _counting(job, stop_at=None, gate=None):
    """Counts up, reporting a falling objective, until cancelled or stop_at."""
    k = 0
    while stop_at is None or k < stop_at:
        if gate is not None:
            gate.wait()
        cb = job.callback("counting", max_iterations=stop_at or 1000)
        if not cb(k, 1.0 / (k + 1)):
            break
        k += 1
        time.sleep(0.001)
    return k


def test_job_runs_in_a_worker_thread_and_reports_progress(installed):
    jobs = addon().jobs
    seen = {}

    def fn(job):
        seen["thread"] = threading.current_thread()
        return _counting(job, stop_at=50)

    job = jobs.begin(jobs.Job("count", fn))
    try:
        assert job.wait(10)
    finally:
        jobs.end(job)
    assert seen["thread"] is not threading.main_thread()
    assert job.result == 50 and job.error is None and not job.cancelled
    snap = job.snapshot()
    assert snap["fraction"] == pytest.approx(1.0)
    assert snap["objective"] == pytest.approx(1.0 / 50)
    assert [it for it, _ in job.history] == list(range(50))


def test_cancel_stops_the_worker_and_drops_the_result(installed):
    jobs = addon().jobs
    job = jobs.begin(jobs.Job("endless", lambda j: _counting(j)))
    try:
        while len(job.history) < 5:
            time.sleep(0.005)
        job.cancel()
        assert job.wait(10)
    finally:
        jobs.end(job)
    assert job.cancelled and job.result is None and job.error is None


def test_errors_are_kept_for_the_main_thread(installed):
    jobs = addon().jobs
    from seamfit.errors import SolveError

    def fn(job):
        raise SolveError("the garment fell off the body")

    job = jobs.Job("failing", fn).run_here()
    assert isinstance(job.error, SolveError) and "fell off" in str(job.error)


def test_one_job_at_a_time(installed):
    jobs = addon().jobs
    gate = threading.Event()
    job = jobs.begin(jobs.Job("first", lambda j: _counting(j, stop_at=3, gate=gate)))
    try:
        with pytest.raises(RuntimeError, match="busy with first"):
            jobs.begin(jobs.Job("second", lambda j: 0))
        assert jobs.active() is job
    finally:
        gate.set()
        job.wait(10)
        jobs.end(job)
    assert jobs.active() is None
