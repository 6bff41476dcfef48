"""The driver of ``seamfit batch``: skips the jobs already done under their settings hash,
computes each base's shared work once (a task per base, into the content-keyed disk cache,
before that base's jobs start), submits the jobs to Ray with their resources, and follows
them to the end: the terminal, status.json, each job's record, the summary table."""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import SeamfitError
from . import cluster, records
from . import settings as job_settings
from .tasks import STOP_FILE, JobCrashed, run_job_process, sweep_leftovers

STATUS_EVERY_S = 2.0          # status.json at most this often while nothing finishes
TERMINAL_EVERY_S = 30.0       # a progress line while nothing finishes


@dataclass
class Resources:
    threads: int = 1          # CPU threads of each job (OMP_NUM_THREADS), its Ray num_cpus
    gpus: float = 1.0         # GPU share of a job whose device is cuda (four per card measured best: docs/gpu_sharing.md)
    memory_gb: float = 2.0    # memory each job declares
    retries: int = 2          # retries of a job whose process or worker died


def job_argv(job, out: Path, target_body: Path | None = None) -> list[str]:
    """The ``seamfit grade`` / ``grade-run`` command line of a job (its output folder
    replaced whole: only a job that is not done runs)."""
    argv = [job.kind, str(job.pattern), "--base-body", str(job.base_body)]
    t = job.target
    if job.kind == "grade":
        argv += ["--target-body", str(target_body or t["target_body"])]
        if job.truth is not None:
            argv += ["--truth", str(job.truth)]
    elif "target_bodies" in t:
        argv += ["--target-bodies", *map(str, t["target_bodies"])]
    else:
        argv += ["--size-chart", str(t["size_chart"])]
    return argv + ["--out", str(out / job.id), "--force", *job_settings.to_argv(job.settings)]


def job_spec(job, out: Path) -> dict:
    spec = {"op": "grade", "job": job.id, "out": str(out)}
    if job.kind == "grade" and "target_body" not in job.target:
        body = out / "bodies" / f"{job.id}.obj"
        source = job.target.get("measurements") or job.target["size_chart"]
        return {**spec, "argv": job_argv(job, out, body),
                "make_body": {"file": str(source), "size": job.target.get("size"), "out": str(body)}}
    return {**spec, "argv": job_argv(job, out)}


# What a base's shared work depends on: the pattern, the base body and these settings.
BASE_SETTINGS = ("edge_length", "sdf_spacing", "sdf_region", "sdf_margin", "device")


def base_key(job) -> tuple:
    s = {**job_settings.defaults(), **job.settings}
    return (str(job.pattern), str(job.base_body), *(s[k] for k in BASE_SETTINGS))


def base_argv(job) -> list[str]:
    shared = {k: v for k, v in job.settings.items() if k in BASE_SETTINGS}
    return [str(job.pattern), str(job.base_body), *job_settings.to_argv(shared)]


def _last_line(log: Path) -> str:
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    errors = [ln for ln in lines if ": error: " in ln or "internal error" in ln]
    return (errors or [ln for ln in lines if not ln.startswith("--- seamfit batch")] or [""])[-1]


def run_batch(manifest: Path, jobs: list, out: Path, *, address: str | None, cpus: int | None,
              res: Resources, cache_dir: Path | None, quiet: bool) -> int:
    """Run ``jobs``; 0 when every job's results are written, 1 when any job failed or
    exited 1 (the others are written)."""
    import ray

    out = Path(os.path.abspath(out))
    if out.exists() and not out.is_dir():
        raise SeamfitError(f"{out}: exists and is not a folder")
    for sub in ("jobs", "logs", "running", "bodies"):
        (out / sub).mkdir(parents=True, exist_ok=True)

    def say(line: str, always: bool = False) -> None:
        if always or not quiet:            # -q keeps a failed job's line: a batch never fails silently
            print(line, file=sys.stderr, flush=True)

    status = records.Status(out, manifest, [j.id for j in jobs])
    final: dict[str, dict] = {}
    todo = []
    for job in jobs:
        digest = records.settings_hash(job)
        rec = records.is_done(out, job, digest)
        if rec is not None:
            final[job.id] = {**rec, "state": "skipped"}
            status.set(job.id, "skipped")
        else:
            todo.append((job, digest))
            for stale in (out / "running" / f"{job.id}.json", out / "logs" / f"{job.id}.log"):
                stale.unlink(missing_ok=True)      # a new run: attempts counted afresh
            sweep_leftovers(out, job.id)
    say(f"seamfit batch: {len(jobs)} job{'s' if len(jobs) != 1 else ''}, {len(jobs) - len(todo)} already done (skipped), {len(todo)} to run")
    status.write()
    if not todo:
        return _finish(out, jobs, final, status, say)

    env = {}
    if cache_dir is not None:
        env["SEAMFIT_CACHE_DIR"] = str(Path(os.path.abspath(cache_dir)))
    # Each job process imports the seamfit of the worker that starts it (seamfit.batch.tasks).
    (out / "running" / STOP_FILE).unlink(missing_ok=True)
    started_ray = not ray.is_initialized()
    if started_ray:
        handler = signal.getsignal(signal.SIGTERM)
        if address:
            cluster.connect(ray, address, out)       # or a one-line error naming the address
        else:
            # the workers Ray starts here import this seamfit
            package_root = str(Path(__file__).resolve().parents[2])
            os.environ["PYTHONPATH"] = os.pathsep.join([package_root, *filter(None, [os.environ.get("PYTHONPATH")])])
            ray.init(include_dashboard=False, log_to_driver=False, logging_level="ERROR", num_cpus=cpus)
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, handler)   # ray.init puts in its own (sys.exit): seamfit's stops the jobs
    try:
        if address and started_ray:
            cluster.check_workers(ray, res.threads, say)
        check_fits(ray, res, any(_device(job) == "cuda" for job, _ in todo))
        return _drive(ray, out, jobs, todo, final, status, res, env, say)
    finally:
        if started_ray:
            ray.shutdown()


def _device(job) -> str:
    return {**job_settings.defaults(), **job.settings}["device"]


def check_fits(ray, res: Resources, gpu_jobs: bool) -> None:
    """A job that asks for more than any node has would wait for ever: say so at once."""
    nodes = [n.get("Resources", {}) for n in ray.nodes() if n.get("Alive")]
    most = {k: max((n.get(k, 0.0) for n in nodes), default=0.0) for k in ("CPU", "GPU", "memory")}
    if res.threads > most["CPU"]:
        raise SeamfitError(f"--threads-per-job {res.threads}: no Ray node has that many CPUs "
                           f"(at most {most['CPU']:g})")
    if res.memory_gb * 1024 ** 3 > most["memory"]:
        raise SeamfitError(f"--memory-per-job {res.memory_gb:g}: no Ray node has that much memory for tasks "
                           f"(at most {most['memory'] / 1024 ** 3:.1f} GB); give less")
    if gpu_jobs and res.gpus > most["GPU"]:
        raise SeamfitError(f"jobs with device cuda need --gpus-per-job {res.gpus:g} of a GPU, and no Ray node "
                           + ("has a GPU" if not most["GPU"] else f"has more than {most['GPU']:g}"))


def _drive(ray, out, jobs, todo, final, status, res, env, say) -> int:
    task = ray.remote(run_job_process)
    gb = 1024 ** 3

    def options(job, name):
        cuda = _device(job) == "cuda"
        return task.options(num_cpus=res.threads, num_gpus=res.gpus if cuda else 0,
                            memory=int(res.memory_gb * gb), max_retries=res.retries,
                            retry_exceptions=[JobCrashed], name=name)

    pending: dict = {}
    t_submit: dict = {}

    def submit(job, digest):
        ref = options(job, f"seamfit {job.id}").remote(
            job_spec(job, out), str(out / "logs" / f"{job.id}.log"), str(out / "running" / f"{job.id}.json"),
            res.threads, env)
        pending[ref] = ("job", job, digest)

    groups: dict = {}
    for job, digest in todo:
        groups.setdefault(base_key(job), []).append((job, digest))
    for n, (key, members) in enumerate(groups.items(), 1):
        if len(members) < 2:
            for m in members:
                submit(*m)
            continue
        job = members[0][0]
        name = f"base-{n}"
        ref = options(job, f"seamfit {name}").remote(
            {"op": "prepare", "argv": base_argv(job)}, str(out / "logs" / f"{name}.log"),
            str(out / "running" / f"{name}.json"), res.threads, env)
        pending[ref] = ("base", members, name)

    last_status = last_line = time.time()
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
            for ref in ready:
                what = pending.pop(ref)
                if what[0] == "base":
                    _base_done(ray, ref, what[2], out, say)
                    for m in what[1]:
                        submit(*m)
                    continue
                job, digest = what[1], what[2]
                rec = _job_done(ray, ref, job, digest, out)
                records.write_record(out, rec)
                (out / "running" / f"{job.id}.json").unlink(missing_ok=True)
                final[job.id] = rec
                status.set(job.id, rec["state"], gradings=(rec.get("results") or {}).get("sizes", 1)
                           if rec["state"] == "done" else 0)
                if rec["state"] == "done":
                    say(f"done    {job.id}: exit {rec['exit']}, {rec['seconds']:.1f} s")
                else:
                    say(f"FAILED  {job.id}: {rec['reason']} (log: {out / rec['log']})", always=True)
            _mark_running(out, status)
            now = time.time()
            if ready or now - last_status > STATUS_EVERY_S:
                status.write()
                last_status = now
            if ready or now - last_line > TERMINAL_EVERY_S:
                say(status.line())
                last_line = now
    except BaseException:
        _stop_processes(out)         # each cleans up its temporary folder, as grade does on Ctrl-C
        for ref in pending:
            ray.cancel(ref, force=True)
        # Ray may have started a queued job while the first ones ended: stop it too, and let
        # no marker or status say a job still runs.
        _stop_processes(out, wait_s=2.0)
        _clear_markers(out)
        for job_id, state in list(status.state.items()):
            if state == "running":
                status.state[job_id] = "queued"
        _finish(out, jobs, final, status, say, interrupted=True)
        raise
    return _finish(out, jobs, final, status, say)


def _stop_processes(out: Path, wait_s: float = 10.0) -> None:
    """SIGTERM to the job processes of this machine (a cluster's other nodes lose theirs
    with their workers), and a wait for them to end."""
    import json
    import socket
    pids = []
    (out / "running" / STOP_FILE).touch()      # the tasks: a process ended by us is not a crash
    for marker in (out / "running").glob("*.json"):
        try:
            m = json.loads(marker.read_text())
            cmdline = Path(f"/proc/{int(m['pid'])}/cmdline").read_bytes()
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if m.get("host") == socket.gethostname() and b"seamfit.batch.job" in cmdline:
            try:
                os.kill(int(m["pid"]), signal.SIGTERM)
                pids.append(int(m["pid"]))
            except OSError:
                pass
    deadline = time.time() + wait_s
    while pids and time.time() < deadline:
        pids = [p for p in pids if Path(f"/proc/{p}").exists()]
        time.sleep(0.1)


def _clear_markers(out: Path) -> None:
    """Remove the running markers of this machine's job processes that are gone."""
    import json
    import socket
    for marker in (out / "running").glob("*.json"):
        try:
            m = json.loads(marker.read_text())
            if m.get("host") != socket.gethostname():
                continue
            alive = b"seamfit.batch.job" in Path(f"/proc/{int(m['pid'])}/cmdline").read_bytes()
        except (OSError, ValueError, KeyError, TypeError):
            alive = False
        if not alive:
            marker.unlink(missing_ok=True)


def _mark_running(out: Path, status) -> None:
    for job_id, state in list(status.state.items()):
        if state in ("queued", "running"):
            status.state[job_id] = "running" if (out / "running" / f"{job_id}.json").exists() else "queued"


def _base_done(ray, ref, name, out, say) -> None:
    try:
        r = ray.get(ref)
        ok = r["exit"] == 0
    except Exception:
        ok = False
    (out / "running" / f"{name}.json").unlink(missing_ok=True)
    if not ok:     # the jobs make it themselves, and each says why in its own log
        say(f"note    {name}: the base's shared work failed ({_last_line(out / 'logs' / f'{name}.log')}); "
            "its jobs build it themselves")


def _job_done(ray, ref, job, digest, out) -> dict:
    log = out / "logs" / f"{job.id}.log"
    rec = {"id": job.id, "kind": job.kind, "hash": digest, "log": str(log.relative_to(out)),
           "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    try:
        r = ray.get(ref)
    except Exception as exc:
        attempts = _attempts(out, job.id)
        cause = "worker lost" if not isinstance(getattr(exc, "cause", None), JobCrashed) else "process killed"
        return {**rec, "state": "failed", "exit": None, "seconds": None, "attempts": attempts,
                "reason": f"{cause} on each of {attempts} attempts"}
    rec.update(exit=r["exit"], seconds=r["seconds"], attempts=r["attempts"])
    if r["exit"] in (0, 1):
        try:
            rec["results"] = records.results_of(out / job.id, job.kind)
            return {**rec, "state": "done"}
        except (OSError, ValueError, KeyError) as exc:
            return {**rec, "state": "failed", "reason": f"its results cannot be read: {exc}"}
    return {**rec, "state": "failed", "reason": f"exit {r['exit']}: {_last_line(log)}"}


def _attempts(out: Path, job_id: str) -> int:
    try:
        return (out / "logs" / f"{job_id}.log").read_text(errors="replace").count("--- seamfit batch: attempt ")
    except OSError:
        return 0


def _finish(out, jobs, final, status, say, interrupted: bool = False) -> int:
    rows = [final.get(j.id, {"id": j.id, "kind": j.kind, "state": "not run" if interrupted else "queued"})
            for j in jobs]
    records.write_summary(out, rows)
    snap = status.write()
    say(records.table(rows))
    say(f"seamfit batch: {snap['done']} done, {snap['skipped']} skipped, {snap['failed']} failed of {snap['total']}; "
        f"wrote {out}/summary.json, summary.csv, status.json")
    bad = any(r.get("state") == "failed" or r.get("exit") == 1 for r in rows)
    return 1 if bad else 0
