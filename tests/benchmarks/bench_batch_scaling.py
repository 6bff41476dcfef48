"""Throughput of `seamfit batch` against the number of workers, on CPU cores and on GPUs.

Every configuration runs its own manifest of identical-cost gradings (the sample pencil
skirt, bodice and circle skirt graded to the sample size-10 and apple bodies, in turn) on a
fresh local Ray, after one warm-up batch has filled the content-keyed cache with the bases'
work (meshes aside, which every job makes): the table is the steady state of a shop that
grades one style to many customers. Each configuration gets ``--rounds`` jobs per worker
(default 2, at least 4 in all); its wall time includes Ray's start.

    export PYTHONPATH=$PWD/native/python
    python tests/benchmarks/bench_batch_scaling.py run --out scaling.json --workers 1,2,4,8,16 \
        [--gpus 1,2 --gpu-share 0.25]
    python tests/benchmarks/bench_batch_scaling.py report scaling.json [more.json ...]

``report`` writes docs/batch_scaling.md and docs/img/batch_scaling.png.
"""
from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

from bench_cli import Commands

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SAMPLES = ROOT / "sample_files"
PATTERNS = ("gc_pencil_skirt", "fs_bodice", "gc_circle_skirt")
TARGETS = ("women_size10", "women_apple")
# A coarse grading: a few seconds on one core, the cost the 50-job example manifest has.
SETTINGS = {"edge_length": 4, "sdf_spacing": 0.005, "max_iterations": 16, "checkpoint_every": 8,
            "no_picture": True}


def manifest(n_jobs: int, device: str, folder: Path) -> Path:
    jobs = []
    combos = [(p, t) for p in PATTERNS for t in TARGETS]
    for k in range(n_jobs):
        p, t = combos[k % len(combos)]
        jobs.append({"id": f"j{k:04d}-{p}-{t}", "pattern": str(SAMPLES / "patterns" / p / "size06" / "pattern.json"),
                     "target_body": str(SAMPLES / "bodies" / f"{t}.obj")})
    spec = {"defaults": {"base_body": str(SAMPLES / "bodies" / "women_size06.obj"), "device": device, **SETTINGS},
            "jobs": jobs}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"manifest_{device}_{n_jobs}.json"
    path.write_text(json.dumps(spec, indent=1))
    return path


def batch(path: Path, out: Path, extra: list[str], env: dict) -> dict:
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "seamfit", "batch", str(path), "--out", str(out), "-q", *extra],
                          env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    summary = {}
    if (out / "summary.json").is_file():
        summary = json.loads((out / "summary.json").read_text())
    rows = summary.get("jobs", []) if isinstance(summary, dict) else summary
    secs = sorted(float(r.get("seconds") or 0) for r in rows if r.get("state", r.get("status")) in ("done", "ok"))
    return {"exit": proc.returncode, "wall_s": wall, "done": len(secs),
            "job_seconds_median": secs[len(secs) // 2] if secs else None,
            "stderr_tail": proc.stderr[-800:] if proc.returncode else ""}


def cmd_run(a) -> int:
    work = Path(a.work)
    env = dict(os.environ)
    env["SEAMFIT_CACHE_DIR"] = str(work / "cache")
    results = {"rounds": a.rounds, "machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                           "python": platform.python_version(), "host": platform.node()},
               "settings": SETTINGS, "command": " ".join(sys.argv), "rows": []}
    say = lambda m: print(m, flush=True)  # noqa: E731
    workers = [int(w) for w in a.workers.split(",") if w]
    gpus = [int(g) for g in a.gpus.split(",") if g]
    # Warm the cache: bases' fields and drapes, the device choice.
    for device in ["cpu"] + (["cuda"] if gpus else []):
        r = batch(manifest(len(PATTERNS) * len(TARGETS), device, work), work / f"warm_{device}",
                  ["--cpus", str(max(workers))], env)
        say(f"warm-up {device}: {r}")
    for w in workers:
        n = max(4, a.rounds * w)
        r = batch(manifest(n, "cpu", work), work / f"cpu_{w}", ["--cpus", str(w)], env)
        r.update(kind="cpu", workers=w, jobs=n, per_hour=3600.0 * r["done"] / r["wall_s"])
        results["rows"].append(r)
        say(f"cpu {w} workers: {n} jobs, {r['done']} done in {r['wall_s']:.1f} s, {r['per_hour']:.0f}/h")
    for g in gpus:
        per_gpu = int(round(1 / a.gpu_share))
        n = max(4, a.rounds * g * per_gpu)
        genv = dict(env, CUDA_VISIBLE_DEVICES=",".join(str(i) for i in range(g)))
        r = batch(manifest(n, "cuda", work), work / f"gpu_{g}",
                  ["--cpus", str(max(workers)), "--gpus-per-job", str(a.gpu_share)], genv)
        r.update(kind="gpu", gpus=g, share=a.gpu_share, workers=g * per_gpu, jobs=n,
                 per_hour=3600.0 * r["done"] / r["wall_s"])
        results["rows"].append(r)
        say(f"{g} GPU(s), {per_gpu} jobs each: {n} jobs, {r['done']} done in {r['wall_s']:.1f} s, {r['per_hour']:.0f}/h")
    Path(a.out).write_text(json.dumps(results, indent=1))
    return 0


def vs_linear(run: dict, r: dict) -> float | None:
    """A CPU row's throughput against one worker's times its workers (None: a GPU row, or no
    one-worker row to compare with)."""
    base = next((x for x in run["rows"] if x["kind"] == "cpu" and x["workers"] == 1), None)
    if r["kind"] != "cpu" or not base or not base["per_hour"]:
        return None
    return r["per_hour"] / (base["per_hour"] * r["workers"])


def cmd_report(a) -> int:
    runs = [json.loads(Path(p).read_text()) for p in a.results]
    lines = ["# `seamfit batch`: throughput against workers", "",
             f"Generated by `tests/benchmarks/bench_batch_scaling.py report` from "
             f"{', '.join(f'`{Path(p).name}`' for p in a.results)}. Each row: a fresh local Ray, "
             "a number of coarse gradings per worker (at least 4 in all), the cache warm; wall time "
             f"includes Ray's start. Grading settings: `{json.dumps(runs[0]['settings'])}`.", ""]
    for run, p in zip(runs, a.results):
        m = run["machine"]
        lines += [f"## {m['cores']} cores ({m['cpu']}), Python {m['python']}", "",
                  f"{run.get('rounds', 2)} jobs per worker. Command: `{run['command']}`", "",
                  "| hardware | workers | jobs | done | wall s | gradings / h | vs linear | median job s |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for r in run["rows"]:
            hw = "CPU" if r["kind"] == "cpu" else f"{r['gpus']} GPU, {r['share']:g} each"
            lin = "-" if vs_linear(run, r) is None else f"{vs_linear(run, r):.2f}x"
            med = f"{r['job_seconds_median']:.1f}" if r.get("job_seconds_median") else "-"
            lines.append(f"| {hw} | {r['workers']} | {r['jobs']} | {r['done']} | {r['wall_s']:.1f} | "
                         f"{r['per_hour']:.0f} | {lin} | {med} |")
        lines.append("")
    notes = Path(a.notes) if a.notes else None
    if notes and notes.is_file():
        lines += [notes.read_text().rstrip(), ""]
    docs = Path(a.docs)
    (docs / "batch_scaling.md").write_text("\n".join(lines))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        for run in runs:
            rows = [r for r in run["rows"] if r["kind"] == "cpu"]
            if rows:
                w = [r["workers"] for r in rows]
                ax.plot(w, [r["per_hour"] for r in rows], "o-", label=f"CPU, {run.get('rounds', 2)} jobs per worker ({run['machine']['cores']} cores)")
                ax.plot(w, [rows[0]["per_hour"] * x / rows[0]["workers"] for x in w], ":", color="grey",
                        label=f"linear from 1 worker ({run.get('rounds', 2)} jobs)")
            for r in run["rows"]:
                if r["kind"] == "gpu":
                    ax.plot([r["workers"]], [r["per_hour"]], "s", label=f"{r['gpus']} GPU ({r['workers']} jobs at once)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("jobs at once")
        ax.set_ylabel("gradings per hour")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(docs / "img" / "batch_scaling.png", dpi=120)
    except ImportError:
        print("matplotlib missing: no plot", file=sys.stderr)
    print(f"wrote {docs / 'batch_scaling.md'}")
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    r = cli.add_run(cmd_run)
    r.add_argument("--work", default="/tmp/seamfit_batch_scaling")
    r.add_argument("--workers", default="1,2")
    r.add_argument("--gpus", default="")
    r.add_argument("--gpu-share", type=float, default=0.25)
    r.add_argument("--rounds", type=int, default=2, help="jobs per worker (default 2)")
    cli.add_report(cmd_report, notes="markdown appended after the table")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
