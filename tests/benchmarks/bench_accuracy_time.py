"""Run time against error: the landmark and ease error a grading has reached after 10 s,
30 s, 100 s ... of wall time, per mesh size (and device), against proportional scaling.

One grading per case and mesh size, with the largest budget; every accepted exact
checkpoint is scored (its pattern against the drafted truth, its drape's ease), so one run
gives the whole curve. The time of a checkpoint counts from the start of the grading, mesh,
body fields and base drape included (cached on disk after a garment's first case, as a user
re-grading sees them).

    python tests/benchmarks/bench_accuracy_time.py run --data DATA --out OUT.json --jobs 16 \\
        --edge-lengths 3,2 --budgets 10,30,100 [--garments a,b] [--bodies x,y] [--device cpu]
    python tests/benchmarks/bench_accuracy_time.py report OUT.json [OUT2.json ...] [--docs docs]
"""
from __future__ import annotations

import json
import multiprocessing
import os
import statistics as st
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
from doc_page import write_page  # noqa: E402
from bench_cli import Commands, add_sweep  # noqa: E402


def run_case(data: str, garment: str, body: str, edge: float, budget: float, device: str) -> dict:
    from accuracy_case import EASE_LEVELS, body_file, measurements_cm
    from bench_objective_alignment import pattern_of
    from seamfit.body import load_body
    from seamfit.opt.fit import ease_report
    from seamfit.opt.grade import GradeSettings, algorithm1
    from seamfit.opt.prepare import prepare
    from seamfit.pattern import landmark_errors, load_pattern
    from seamfit.pattern.scale import proportional_scale

    data = Path(data)
    row = {"garment": garment, "body": body, "edge_length_cm": edge, "device": device, "points": []}
    try:
        base = load_pattern(data / "patterns" / garment / "size06" / "pattern.json")
        truth = load_pattern(data / "patterns" / garment / body / "pattern.json")
        p0, p1 = body_file(data / "bodies", "size06"), body_file(data / "bodies", body)
        b0, b1 = load_body(p0), load_body(p1)
        row["scaled_cm"] = landmark_errors(proportional_scale(base, measurements_cm(data / "bodies", p0, b0),
                                                              measurements_cm(data / "bodies", p1, b1))[0],
                                           truth).max_cm
        seen = []
        t0 = time.perf_counter()

        loop_start = []

        def progress(info):
            if info.get("stage") == "optimize" and not loop_start:   # the initialized start is drawn
                loop_start.append(time.perf_counter() - t0)
            if info.get("exact") and not info.get("backtrack") and info.get("theta") is not None:
                seen.append((time.perf_counter() - t0, info["theta"].copy(), info["x"].copy()))

        settings = GradeSettings(edge_length_cm=edge, time_budget_s=budget, max_outer_iterations=100000,
                                 device=device, evaluate_base_pattern=False)
        ctx = prepare(base, b0, b1, settings, progress=progress)
        base_ease = ease_report(b0, ctx.xbar, ctx.mesh.triangles)
        out = algorithm1(ctx)
        t_end = time.perf_counter() - t0
        seen.insert(0, (loop_start[0] if loop_start else t_end, out.theta_start, out.x_start))  # initialized start
        seen.append((t_end, out.theta, out.x))
        for t, theta, x in seen:
            ease = ease_report(b1, x, ctx.mesh.triangles)
            errs = [abs(ease[k] - base_ease[k]) for k in EASE_LEVELS
                    if ease.get(k) is not None and base_ease.get(k) is not None]
            row["points"].append({"seconds": t, "landmark_max_cm": landmark_errors(pattern_of(ctx, theta), truth).max_cm,
                                  "ease_error_cm": max(errs) if errs else None})
        row["converged"], row["message"] = out.converged, out.message
    except Exception as exc:  # noqa: BLE001 - a benchmark records, never stops
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["traceback"] = traceback.format_exc()[-1500:]
    return row


def _pick_gpu(slot, gpus: int) -> None:
    """Worker k of the pool uses GPU k mod gpus (each worker keeps its GPU for all its cases)."""
    with slot.get_lock():
        k = slot.value
        slot.value += 1
    if gpus > 1:
        os.environ["CUDA_VISIBLE_DEVICES"] = str(k % gpus)


def at(points: list, budget: float):
    """The last scored state reached within ``budget`` seconds (None: none yet)."""
    done = [p for p in points if p["seconds"] <= budget]
    return done[-1] if done else None


def reached(cases: list, budget: float) -> list:
    """The last scored state of each case reached within ``budget`` seconds, for the cases
    that reached one."""
    return [s for s in (at(c["points"], budget) for c in cases) if s is not None]


def cmd_run(a) -> int:
    from bench_accuracy import discover
    pairs = discover(a.data, "size06", a.garments.split(",") if a.garments else None,
                     a.bodies.split(",") if a.bodies else None)
    edges = [float(e) for e in a.edge_lengths.split(",")]
    budget = max(float(b) for b in a.budgets.split(","))
    os.environ["OMP_NUM_THREADS"] = str(a.threads)
    rows = []
    meta = {"command": " ".join(sys.argv), "budgets": [float(b) for b in a.budgets.split(",")],
            "jobs": a.jobs, "threads": a.threads, "cores": os.cpu_count()}
    if a.gpus > 1:
        meta["gpus"] = a.gpus
    ctx = multiprocessing.get_context()
    slot = ctx.Value("i", 0)
    with ProcessPoolExecutor(max_workers=a.jobs, mp_context=ctx, initializer=_pick_gpu,
                             initargs=(slot, a.gpus)) as pool:
        futs = [pool.submit(run_case, str(a.data), g, b, e, budget, a.device) for e in edges for g, b in pairs]
        for fut in as_completed(futs):
            r = fut.result()
            rows.append(r)
            last = r["points"][-1] if r.get("points") else {}
            state = r.get("error") or (f"{len(r['points'])} states, last {last.get('landmark_max_cm', 0):.2f} cm "
                                       f"at {last.get('seconds', 0):.0f} s")
            print(f"{r['garment']}/{r['body']} {r['edge_length_cm']} cm: {state}", flush=True)
            a.out.write_text(json.dumps({"meta": meta, "cases": rows}, indent=1) + "\n")
    return 0


def cmd_report(a) -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [json.loads(p.read_text()) for p in a.results]
    budgets = sorted({b for r in runs for b in r["meta"]["budgets"]})
    rows = [c for r in runs for c in r["cases"] if "error" not in c]
    groups = sorted({(c["edge_length_cm"], c["device"]) for c in rows})
    lines = ["# Run time against error", "",
             "Generated by `tests/benchmarks/bench_accuracy_time.py report` from "
             + ", ".join(f"`{p.name}`" for p in a.results) + ".", ""]
    for r, p in zip(runs, a.results):
        lines.append(f"* `{p.name}`: `{r['meta']['command']}` ({r['meta']['jobs']} gradings at once, "
                     f"{r['meta']['threads']} thread(s) each, {r['meta']['cores']} cores)")
    lines += ["", "Each grading runs once with the largest budget; every accepted exact checkpoint is scored. "
              "The error at t seconds is that of the last checkpoint reached by then, counted from the start "
              "of the grading (mesh, fields and base drape included, cached after a garment's first case). "
              "Landmark: median over cases of the max landmark error against the drafted pattern (cm); ease: "
              "median of the largest |ease - base ease| over the levels the garment encloses (cm); *reached*: "
              "cases with a scored state by then.", "",
              "| mesh cm | device | " + " | ".join(f"{b:g} s: landmark / ease (reached)" for b in budgets)
              + " | scaling |", "|---|---|" + "---|" * (len(budgets) + 1)]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for edge, dev in groups:
        cs = [c for c in rows if c["edge_length_cm"] == edge and c["device"] == dev]
        cells, lm_y, ez_y = [], [], []
        for b in budgets:
            got = reached(cs, b)
            lm = st.median([g["landmark_max_cm"] for g in got]) if got else float("nan")
            ez = [g["ease_error_cm"] for g in got if g["ease_error_cm"] is not None]
            ezm = st.median(ez) if ez else float("nan")
            cells.append(f"{lm:.2f} / {ezm:.2f} ({len(got)}/{len(cs)})")
            lm_y.append(lm)
            ez_y.append(ezm)
        sc = st.median([c["scaled_cm"] for c in cs])
        lines.append(f"| {edge:g} | {dev} | " + " | ".join(cells) + f" | {sc:.2f} |")
        ax[0].plot(budgets, lm_y, "o-", label=f"{edge:g} cm, {dev}")
        ax[0].axhline(sc, ls=":", color="gray")
        ax[1].plot(budgets, ez_y, "o-", label=f"{edge:g} cm, {dev}")
    for k, name in enumerate(("median max landmark error (cm)", "median ease error (cm)")):
        ax[k].set_xscale("log")
        ax[k].set_xlabel("seconds")
        ax[k].set_ylabel(name)
        ax[k].grid(True, alpha=0.3)
    ax[0].legend(title="dotted: proportional scaling")
    fig.tight_layout()
    img = a.docs / "img" / "accuracy_time.png"
    fig.savefig(img, dpi=110)
    lines += ["", "![error against seconds](img/accuracy_time.png)"]
    write_page(a.docs / "accuracy_time.md", lines, a.notes)
    print(f"wrote {img}")
    return 0


def main(argv=None) -> int:
    cli = Commands()
    r = cli.add_run(cmd_run)
    add_sweep(r)
    r.add_argument("--threads", type=int, default=1)
    r.add_argument("--edge-lengths", default="3")
    r.add_argument("--budgets", default="10,30,100")
    r.add_argument("--device", default="cpu")
    r.add_argument("--gpus", type=int, default=1, help="spread the workers over this many GPUs")
    cli.add_report(cmd_report, notes="markdown appended after the table")
    return cli.main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
