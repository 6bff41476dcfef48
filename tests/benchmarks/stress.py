"""Stress suite: randomized drapes and gradings, each in its own process under a time
limit, reporting NaN, crashes, hangs, rising checkpoint objectives and wall time.

    python tests/benchmarks/stress.py run --runs 1000 --jobs 16 --out stress.json [--seed 1] [--threads N]
    python tests/benchmarks/stress.py report stress.json [--notes FILE] [--docs docs]

A run draws, from its own seed:
* a garment of sample_files (the pencil skirt, the circle skirt, the bodice, base size 6)
  and a target body: a sample body, widened about its axis by 0.9-1.15 and stretched in
  height by 0.95-1.05;
* for a drape: the garment started 0-2 cm inside the body (every vertex pushed along -n of
  the field), a barrier strength mu of 10^-3..10^-1, a tolerance of 10^-4..10^-2;
* for a grading: every strength times 10^-2..10^2 or switched off (R^fix stays on: the
  search's preconditioner needs it), mesh 3-6 cm, fields 5-10 mm, 4-32 outer iterations,
  checkpoints every 1-8, inner iterations 1-16, start "level" or "base".

Outcomes: "ok"; "refused" (a seamfit error with its one-line message: a clear refusal, not
a defect); "nan" (a non-finite number in the result); "crash" (any other exception, or the
process died); "hang" (the time limit); "rising" (an accepted checkpoint's objective above
the one before: the search must never accept a worse pattern).
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import statistics
import sys
import time
import traceback
from dataclasses import replace
from pathlib import Path

import numpy as np

from bench_cli import threads_per_job

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SAMPLES = ROOT / "sample_files"
GARMENTS = ("gc_pencil_skirt", "gc_circle_skirt", "fs_bodice")
BODIES = ("women_size06", "women_size10", "women_apple")
OUTCOMES = ("ok", "refused", "nan", "crash", "hang", "rising")


def draw(seed: int) -> dict:
    """The run's random choices, from its seed alone (so a failure is replayed by its seed)."""
    rng = np.random.default_rng(seed)
    spec = {"seed": seed, "kind": "drape" if rng.random() < 0.4 else "grade",
            "garment": str(rng.choice(GARMENTS)), "body": str(rng.choice(BODIES)),
            "widen": float(rng.uniform(0.9, 1.15)), "stretch_up": float(rng.uniform(0.95, 1.05)),
            "edge_length_cm": float(rng.uniform(3.0, 6.0)), "sdf_spacing": float(rng.uniform(0.005, 0.01))}
    if spec["kind"] == "drape":
        spec.update(push_in_m=float(rng.uniform(0.0, 0.02)), mu=float(10 ** rng.uniform(-3, -1)),
                    tolerance=float(10 ** rng.uniform(-4, -2)))
    else:
        strengths = {}
        for name in ("cur", "dis", "smo", "str", "pos", "seam"):
            strengths[name] = 0.0 if rng.random() < 0.2 else float(10 ** rng.uniform(-2, 2))
        strengths["fix"] = float(10 ** rng.uniform(-2, 2))
        spec.update(strengths=strengths, max_outer_iterations=int(rng.integers(4, 33)),
                    checkpoint_every=int(rng.integers(1, 9)), inner_iterations=int(rng.integers(1, 17)),
                    start=str(rng.choice(["level", "base"])))
    return spec


def _body(spec: dict):
    from seamfit.body import load_body
    b = load_body(SAMPLES / "bodies" / f"{spec['body']}.obj")
    v = np.array(b.vertices, dtype=float)
    c = 0.5 * (v[:, :2].min(axis=0) + v[:, :2].max(axis=0))
    v[:, :2] = c + spec["widen"] * (v[:, :2] - c)
    z0 = v[:, 2].min()
    v[:, 2] = z0 + spec["stretch_up"] * (v[:, 2] - z0)
    return replace(b, vertices=v, name=f"{spec['body']}-stressed")


def _finite(*arrays) -> bool:
    return all(np.all(np.isfinite(np.asarray(a, dtype=float))) for a in arrays)


def _drape(spec: dict) -> dict:
    from seamfit.body import build_sdf
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    from seamfit.sim.dressing import initial_positions, sample_sdf
    from seamfit.sim.model import Fabric, SimSettings, Simulator
    pattern = load_pattern(SAMPLES / "patterns" / spec["garment"] / "size06" / "pattern.json")
    body = _body(spec)
    mesh = build_sewn_mesh(pattern, edge_length_cm=spec["edge_length_cm"])
    sdf = build_sdf(body, spacing=spec["sdf_spacing"])
    x0, _ = initial_positions(mesh, pattern, sdf)
    # push every vertex into the body along the field's gradient (a penetrating start)
    h = 1e-4
    grad = np.stack([(sample_sdf(sdf, x0 + h * e) - sample_sdf(sdf, x0 - h * e)) / (2 * h)
                     for e in np.eye(3)], axis=1)
    grad /= np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-12)
    x0 = x0 - spec["push_in_m"] * grad
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(mu=spec["mu"], tolerance=spec["tolerance"], max_seconds=60.0))
    res = sim.drape(x0)
    return {"finite": _finite(res.x), "converged": bool(res.converged), "residual": float(res.residual),
            "min_phi_mm": float(res.min_phi_mm), "message": res.message}


def _grade(spec: dict) -> dict:
    from seamfit.body import load_body
    from seamfit.opt.costs import Strengths
    from seamfit.opt.grade import GradeSettings, grade
    from seamfit.pattern import load_pattern
    pattern = load_pattern(SAMPLES / "patterns" / spec["garment"] / "size06" / "pattern.json")
    base = load_body(SAMPLES / "bodies" / "women_size06.obj")
    settings = GradeSettings(strengths=Strengths(**spec["strengths"]), edge_length_cm=spec["edge_length_cm"],
                             sdf_spacing=spec["sdf_spacing"], max_outer_iterations=spec["max_outer_iterations"],
                             checkpoint_every=spec["checkpoint_every"], inner_iterations=spec["inner_iterations"],
                             start=spec["start"], device="cpu", evaluate_base_pattern=False, time_budget_s=90.0)
    r = grade(pattern, base, _body(spec), settings)
    ck = [c["objective"] for c in r.report["checkpoints"]]
    rising = [i for i in range(1, len(ck)) if ck[i] > ck[i - 1] * (1 + 1e-12) + 1e-300]
    outline = np.concatenate([np.asarray(p.outline_cm) for p in r.pattern.panels])
    return {"finite": _finite(r.x, outline, ck), "rising": rising, "converged": bool(r.report["converged"]),
            "message": r.report["message"], "objective": [ck[0], ck[-1]] if ck else None}


def _child(spec: dict, queue) -> None:
    from seamfit.errors import SeamfitError
    t = time.perf_counter()
    try:
        out = (_drape if spec["kind"] == "drape" else _grade)(spec)
        outcome = "nan" if not out["finite"] else ("rising" if out.get("rising") else "ok")
        queue.put({"outcome": outcome, **out, "seconds": time.perf_counter() - t})
    except SeamfitError as exc:
        msg = str(exc)
        queue.put({"outcome": "refused" if "\n" not in msg.strip() else "crash", "message": msg,
                   "seconds": time.perf_counter() - t})
    except BaseException as exc:  # noqa: BLE001 - the suite records every failure
        queue.put({"outcome": "crash", "message": f"{type(exc).__name__}: {exc}",
                   "traceback": traceback.format_exc(limit=8), "seconds": time.perf_counter() - t})


def run_one(spec: dict, timeout_s: float) -> dict:
    """One run in its own process (a hang or a hard crash cannot take the suite down)."""
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_child, args=(spec, q), daemon=True)
    t = time.perf_counter()
    p.start()
    # join() can return while the process is still being torn down (its sentinel closes
    # before it can be reaped): wait until it is gone or the time is up, not just once.
    deadline = t + timeout_s
    while p.is_alive() and time.perf_counter() < deadline:
        p.join(min(1.0, max(deadline - time.perf_counter(), 0.0)))
    if p.is_alive():
        p.kill()
        p.join()
        return {**spec, "outcome": "hang", "seconds": time.perf_counter() - t}
    try:
        res = q.get(timeout=5)
    except Exception:  # noqa: BLE001 - the process died without a word
        return {**spec, "outcome": "crash", "message": f"process exit code {p.exitcode}",
                "seconds": time.perf_counter() - t}
    return {**spec, **res, "wall": time.perf_counter() - t}


def run(n: int, seed: int, jobs: int, timeout_s: float, out: Path | None = None, threads: int = 0) -> list[dict]:
    import os
    import tempfile
    # the distorted bodies' fields would crowd the user's cache out: a cache of its own
    os.environ.setdefault("SEAMFIT_CACHE_DIR", tempfile.mkdtemp(prefix="seamfit-stress-"))
    # Each run's OpenMP threads, read by the spawned process when it loads the core: jobs
    # that each take every core starve one another (16 x 16 threads on 16 cores made drapes
    # of 2 s take 150-230 s and gradings pass the time limit).
    os.environ["OMP_NUM_THREADS"] = str(threads_per_job(threads, jobs))
    specs = [draw(seed * 100003 + i) for i in range(n)]
    rows: list[dict] = []
    from concurrent.futures import ThreadPoolExecutor, as_completed

    from seamfit.fileio import atomic_write_text

    def save():
        # after every run, so a campaign cut short keeps every run it finished
        if out:
            atomic_write_text(out, json.dumps({"command": " ".join(sys.argv), "seed": seed, "planned": n,
                                               "runs": sorted(rows, key=lambda r: r["seed"])}, indent=1) + "\n")

    with ThreadPoolExecutor(max_workers=jobs) as ex:
        for fut in as_completed([ex.submit(run_one, s, timeout_s) for s in specs]):
            row = fut.result()
            rows.append(row)
            print(f"{row['seed']:>10} {row['kind']:6} {row['garment']:16} {row['outcome']:8} "
                  f"{row.get('seconds', 0):6.1f} s  {str(row.get('message', ''))[:90]}", flush=True)
            save()
    return sorted(rows, key=lambda r: r["seed"])


def summary(rows: list[dict]) -> list[str]:
    lines = ["| kind | runs | " + " | ".join(OUTCOMES) + " | converged | min phi mm (drapes) | median s | max s |",
             "|---|---:|" + "---:|" * len(OUTCOMES) + "---:|---:|---:|---:|"]
    for kind in ("drape", "grade", "all"):
        rs = [r for r in rows if kind == "all" or r["kind"] == kind]
        if not rs:
            continue
        secs = [r.get("seconds", 0.0) for r in rs]
        phi = [r["min_phi_mm"] for r in rs if r.get("min_phi_mm") is not None]
        counts = " | ".join(str(sum(r["outcome"] == o for r in rs)) for o in OUTCOMES)
        converged = sum(bool(r.get("converged")) for r in rs)
        lines.append(f"| {kind} | {len(rs)} | {counts} | {converged} | " + (f"{min(phi):.2f}" if phi else "-"))
        lines[-1] += f" | {statistics.median(secs):.1f} | {max(secs):.1f} |"
    return lines


def report(path: Path, docs: Path, notes: Path | None = None) -> Path:
    data = json.loads(path.read_text())
    note = notes.read_text().strip() if notes else None
    rows = data["runs"]
    bad = [r for r in rows if r["outcome"] not in ("ok", "refused")]
    refused = sorted({str(r.get("message", ""))[:120] for r in rows if r["outcome"] == "refused"})
    text = ["# Stress suite: randomized drapes and gradings", "",
            f"Generated by `tests/benchmarks/stress.py report` from `{path.name}` "
            f"(command: `{data['command']}`).", "",
            *([f"{len(rows)} of the {data['planned']} planned runs finished before the campaign was "
               "stopped; the table counts those.", ""] if data.get("planned", len(rows)) > len(rows) else []),
            "Each run draws a garment, a distorted body and extreme legal settings from its seed and "
            "runs in its own process under a time limit (module docstring of "
            "`tests/benchmarks/stress.py`).", "", *([note, ""] if note else []), *summary(rows), "",
            "## Runs that were not ok or refused", ""]
    text += [f"* seed {r['seed']} ({r['kind']}, {r['garment']}): **{r['outcome']}**, "
             f"{str(r.get('message', ''))[:200]}" for r in bad] or ["None."]
    drapes = [r for r in rows if r["kind"] == "drape" and r.get("min_phi_mm") is not None]
    if drapes:
        worst = min(drapes, key=lambda r: r["min_phi_mm"])
        inside = sorted(r["min_phi_mm"] for r in drapes)
        text += ["", "## How far the drapes ended inside the body's field", "",
                 f"Every drape's least signed distance to the body (negative: inside the field, which the "
                 f"barrier keeps shallow): median {statistics.median(inside):.2f} mm, worst "
                 f"{worst['min_phi_mm']:.2f} mm (seed {worst['seed']}: barrier strength mu {worst['mu']:.4f}, "
                 f"started {100 * worst['push_in_m']:.2f} cm inside, fields at {1000 * worst['sdf_spacing']:.1f} mm); "
                 f"{sum(v < -1.0 for v in inside)} of {len(inside)} deeper than 1 mm."]
    text += ["", "## Refusals (one-line messages)", ""] + ([f"* {m}" for m in refused] or ["None."])
    out = docs / "stress_results.md"
    out.write_text("\n".join(text) + "\n")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--runs", type=int, default=1000)
    r.add_argument("--seed", type=int, default=1)
    r.add_argument("--jobs", type=int, default=2)
    r.add_argument("--timeout", type=float, default=300.0, help="seconds before a run counts as a hang")
    r.add_argument("--out", type=Path, default=None)
    r.add_argument("--threads", type=int, default=0, help="OpenMP threads per run (default cores / jobs)")
    p = sub.add_parser("report")
    p.add_argument("results", type=Path)
    p.add_argument("--docs", type=Path, default=ROOT / "docs")
    p.add_argument("--notes", type=Path, default=HERE / "stress_note.md",
                   help="the reading of the run, put above the table (default tests/benchmarks/stress_note.md)")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        rows = run(a.runs, a.seed, a.jobs, a.timeout, a.out, a.threads)
        print("\n".join(summary(rows)))
        return 0
    print(f"wrote {report(a.results, a.docs, a.notes)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
