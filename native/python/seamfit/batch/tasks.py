"""The Ray tasks. Each runs one job's process (seamfit.batch.job) with its log, and tells
the driver which process it is through a marker file (``running/<id>.json``: worker and
process ids, attempt). A process that dies of a signal (killed, out of memory, a crash in
native code) raises JobCrashed, which Ray retries like a lost worker, up to the task's
``max_retries``; an exit code is the job's answer and is not retried."""
from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path


# In running/: the driver is stopping the batch and ends the job processes itself.
STOP_FILE = "STOP"


class JobCrashed(RuntimeError):
    """The job's process died of a signal: retried."""


def _attempt(marker: Path) -> int:
    try:
        return int(json.loads(marker.read_text()).get("attempt", 0)) + 1
    except (OSError, ValueError, AttributeError):
        return 1


def run_job_process(spec: dict, log: str, marker: str, threads: int, env: dict) -> dict:
    """Run the job described by ``spec`` in its own process; its exit code, seconds and
    attempt number."""
    from ..fileio import atomic_write_text
    log, marker = Path(log), Path(marker)
    attempt = _attempt(marker)
    if attempt > 1 and spec.get("job"):
        sweep_leftovers(Path(spec["out"]), spec["job"])
    log.parent.mkdir(parents=True, exist_ok=True)
    # The job runs the seamfit this worker runs (whichever its node's Ray finds: installed, or
    # by PYTHONPATH), not a path of the driver's machine.
    here = str(Path(__file__).resolve().parents[2])
    pythonpath = os.pathsep.join([here, *filter(None, [os.environ.get("PYTHONPATH")])])
    child_env = {**os.environ, **env, "PYTHONPATH": pythonpath, "OMP_NUM_THREADS": str(threads),
                 "PYTHONUNBUFFERED": "1"}
    t0 = time.time()
    with open(log, "a", encoding="utf-8") as f:
        f.write(f"--- seamfit batch: attempt {attempt} on {socket.gethostname()}, worker pid {os.getpid()}, "
                f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        f.flush()
        proc = subprocess.Popen([sys.executable, "-m", "seamfit.batch.job", json.dumps(spec)], stdin=subprocess.DEVNULL,
                                stdout=f, stderr=subprocess.STDOUT, env=child_env)
        atomic_write_text(marker, json.dumps({"worker_pid": os.getpid(), "pid": proc.pid, "attempt": attempt,
                                              "host": socket.gethostname(), "started": t0}) + "\n")
        rc = proc.wait()
        if rc < 0:
            f.write(f"--- seamfit batch: the job's process died of signal {-rc}\n")
    if rc < 0 and not (marker.parent / STOP_FILE).exists():
        raise JobCrashed(f"the job's process died of signal {-rc} (attempt {attempt})")
    return {"exit": rc, "seconds": round(time.time() - t0, 2), "attempts": attempt}


def sweep_leftovers(out: Path, job_id: str) -> None:
    """Temporary folders of a job's earlier attempt that died by SIGKILL (never a result:
    docs/cli.md, "Output sets")."""
    from ..output_set import OLD_TAG, TMP_TAG
    for tag in (TMP_TAG, OLD_TAG):
        for p in out.glob(f".{job_id}{tag}*"):
            shutil.rmtree(p, ignore_errors=True)
