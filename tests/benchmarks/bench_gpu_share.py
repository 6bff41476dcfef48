"""How many gradings at the default settings share one GPU well: K `seamfit grade` processes
at once on one card (K = 1, 2, 4, 8, ...), each grading the sample pencil skirt from size 6
to the size-10 and apple bodies in turn, the cache warm (the steady state of a shop grading
one style to many customers). Each row reports gradings per hour, the median seconds of one
grading, its landmark error against the drafted size, and the card's peak memory and mean
utilization (nvidia-smi, sampled every 0.2 s). The same rows on the CPU alone (``--device
cpu``, the host's cores shared out) put the card's figures in proportion.

    export PYTHONPATH=$PWD/native/python
    python tests/benchmarks/bench_gpu_share.py run --out share.json --at-once 1,2,4,8 [--rounds 3]
        [--device cuda] [--cpu-at-once 1,4,16]
    python tests/benchmarks/bench_gpu_share.py report share.json [--docs docs]

``report`` writes docs/gpu_sharing.md.
"""
from __future__ import annotations

import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

from bench_cli import Commands, threads_per_job

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_files"
PATTERN = SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json"
TARGETS = ("women_size10", "women_apple")
TRUTH = {"women_size10": SAMPLES / "patterns" / "gc_pencil_skirt" / "size10" / "pattern.json",
         "women_apple": None}


class GpuSampler(threading.Thread):
    """Peak memory (MiB) and mean utilization (%) of GPU 0 while it runs."""

    def __init__(self):
        super().__init__(daemon=True)
        self.mem, self.util, self.stop = [], [], threading.Event()

    def run(self):
        while not self.stop.is_set():
            try:
                out = subprocess.run(["nvidia-smi", "--query-gpu=memory.used,utilization.gpu",
                                      "--format=csv,noheader,nounits", "-i", "0"],
                                     capture_output=True, text=True, timeout=5).stdout.split(",")
                self.mem.append(float(out[0]))
                self.util.append(float(out[1]))
            except (OSError, ValueError, IndexError, subprocess.TimeoutExpired):
                return
            self.stop.wait(0.2)

    def summary(self) -> dict:
        return {"gpu_mem_peak_mib": max(self.mem) if self.mem else None,
                "gpu_util_mean_pct": statistics.mean(self.util) if self.util else None}


def grading(k: int, out: Path, device: str, threads: int, env: dict) -> subprocess.Popen:
    target = TARGETS[k % len(TARGETS)]
    cmd = [sys.executable, "-m", "seamfit", "grade", str(PATTERN),
           "--base-body", str(SAMPLES / "bodies" / "women_size06.obj"),
           "--target-body", str(SAMPLES / "bodies" / f"{target}.obj"),
           "--device", device, "--out", str(out), "--force", "-q"]
    if TRUTH[target] is not None:
        cmd += ["--truth", str(TRUTH[target])]
    return subprocess.Popen(cmd, env=dict(env, OMP_NUM_THREADS=str(threads)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def row(at_once: int, rounds: int, device: str, work: Path, env: dict) -> dict:
    """``at_once`` workers, each running ``rounds`` gradings one after the other."""
    threads = threads_per_job(0, at_once)
    sampler = GpuSampler() if device == "cuda" else None
    if sampler:
        sampler.start()
    secs, errors, failed = [], [], 0
    lock = threading.Lock()

    def worker(w: int):
        nonlocal failed
        for r in range(rounds):
            out = work / f"{device}_{at_once}" / f"w{w}_r{r}"
            shutil.rmtree(out, ignore_errors=True)
            t0 = time.perf_counter()
            p = grading(w * rounds + r, out, device, threads, env)
            _, err = p.communicate()
            dt = time.perf_counter() - t0
            with lock:
                if p.returncode != 0 or not (out / "report.json").is_file():
                    failed += 1
                    print(f"  failed ({p.returncode}): {err[-300:]}", file=sys.stderr)
                    continue
                secs.append(dt)
                acc = json.loads((out / "report.json").read_text()).get("accuracy") or {}
                if acc.get("graded"):
                    errors.append(acc["graded"]["max_cm"])

    t0 = time.perf_counter()
    pool = [threading.Thread(target=worker, args=(w,)) for w in range(at_once)]
    for t in pool:
        t.start()
    for t in pool:
        t.join()
    wall = time.perf_counter() - t0
    if sampler:
        sampler.stop.set()
        sampler.join()
    done = len(secs)
    out = {"device": device, "at_once": at_once, "threads_each": threads, "gradings": at_once * rounds,
           "done": done, "failed": failed, "wall_s": wall, "per_hour": 3600.0 * done / wall if wall else 0.0,
           "grading_s_median": statistics.median(secs) if secs else None,
           "error_cm_median": statistics.median(errors) if errors else None,
           "error_cm_max": max(errors) if errors else None}
    if sampler:
        out.update(sampler.summary())
    return out


def cmd_run(a) -> int:
    work = Path(a.work)
    env = dict(os.environ, SEAMFIT_CACHE_DIR=str(work / "cache"))
    res = {"command": " ".join(sys.argv), "rounds": a.rounds,
           "machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                       "python": platform.python_version(), "gpu": gpu_name()},
           "grading": f"seamfit grade {PATTERN.relative_to(ROOT)} at every default, to the size-10 and apple bodies in turn",
           "rows": []}
    devices = [(a.device, [int(k) for k in a.at_once.split(",") if k])]
    if a.cpu_at_once:
        devices.append(("cpu", [int(k) for k in a.cpu_at_once.split(",") if k]))
    for device, ks in devices:
        # Warm-up: the bases' fields and drape, the device choice, one per target.
        for k in range(len(TARGETS)):
            p = grading(k, work / f"warm_{device}_{k}", device, os.cpu_count() or 1, env)
            p.communicate()
        for k in ks:
            r = row(k, a.rounds, device, work, env)
            res["rows"].append(r)
            print(json.dumps(r), flush=True)
    Path(a.out).write_text(json.dumps(res, indent=1))
    return 0


def gpu_name() -> str | None:
    try:
        return subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader", "-i", "0"],
                              capture_output=True, text=True, timeout=10).stdout.strip() or None
    except (OSError, subprocess.TimeoutExpired):
        return None


def vs_one(run: dict, r: dict) -> float | None:
    """A row's throughput against one grading at a time on the same device (None: no such row)."""
    one = next((x for x in run["rows"] if x["device"] == r["device"] and x["at_once"] == 1), None)
    return r["per_hour"] / one["per_hour"] if one and one["per_hour"] else None


def cmd_report(a) -> int:
    runs = [json.loads(Path(p).read_text()) for p in a.results]
    lines = ["# Gradings at the default settings sharing one GPU", "",
             f"Generated by `tests/benchmarks/bench_gpu_share.py report` from "
             f"{', '.join(f'`{Path(p).name}`' for p in a.results)}.", ""]
    for run in runs:
        m = run["machine"]
        lines += [f"## {m.get('gpu') or 'no GPU'}, {m['cores']} cores, Python {m['python']}", "",
                  f"{run['grading']}; {run['rounds']} gradings per worker, one after the other; the "
                  f"cache warm. Command: `{run['command']}`", "",
                  "| device | at once | threads each | gradings | wall s | gradings / h | vs one at once | "
                  "median grading s | landmark error cm (median / max, size 10) | GPU memory peak MiB | "
                  "GPU busy % |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"]
        for r in run["rows"]:
            rel = "-" if vs_one(run, r) is None else f"{vs_one(run, r):.2f}x"
            err = (f"{r['error_cm_median']:.2f} / {r['error_cm_max']:.2f}" if r.get("error_cm_median") is not None
                   else "-")
            mem = f"{r['gpu_mem_peak_mib']:.0f}" if r.get("gpu_mem_peak_mib") is not None else "-"
            util = f"{r['gpu_util_mean_pct']:.0f}" if r.get("gpu_util_mean_pct") is not None else "-"
            med = f"{r['grading_s_median']:.1f}" if r.get("grading_s_median") else "-"
            lines.append(f"| {r['device']} | {r['at_once']} | {r['threads_each']} | {r['done']} of {r['gradings']} | "
                         f"{r['wall_s']:.1f} | {r['per_hour']:.0f} | {rel} | {med} | {err} | {mem} | {util} |")
        lines.append("")
    if a.notes and Path(a.notes).is_file():
        lines += [Path(a.notes).read_text().rstrip(), ""]
    out = Path(a.docs) / "gpu_sharing.md"
    out.write_text("\n".join(lines))
    print(f"wrote {out}")
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__.splitlines()[0])
    r = cli.add_run(cmd_run)
    r.add_argument("--work", default="/tmp/seamfit_gpu_share")
    r.add_argument("--at-once", default="1,2,4,8", help="gradings at once on the device")
    r.add_argument("--rounds", type=int, default=3, help="gradings per worker (default 3)")
    r.add_argument("--device", default="cuda")
    r.add_argument("--cpu-at-once", default="", help="the same rows on the CPU alone, e.g. 1,4,16")
    cli.add_report(cmd_report, notes="markdown appended after the table")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
