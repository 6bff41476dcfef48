"""Does the grading objective f prefer the pattern a pattern maker drafted?

For every shared garment x body case, the drafted truth pattern (the same drafting system's
pattern for the target body) is put on the base mesh, draped on the target body from the
same start as the grading, and f is evaluated on it term by term; likewise the unchanged
pattern, proportional scaling, the level-scaled start, the initialized start (Section 7)
and the graded result. Each candidate's landmark error against the truth is scored too (the
truth's own is the error of putting it on the mesh).

    python tests/benchmarks/bench_objective_alignment.py run --data DATA --out OUT.json --jobs 16
    python tests/benchmarks/bench_objective_alignment.py report OUT.json [--docs docs]

If f(truth) < f(graded) the search is failing; if f(truth) > f(graded) the objective
prefers patterns no pattern maker would draft, and the terms say which part.
"""
from __future__ import annotations

import json
import os
import statistics as st
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
from doc_page import write_page  # noqa: E402
from draft_on_mesh import truth_on_mesh  # noqa: E402
from bench_cli import Commands, add_sweep  # noqa: E402

CANDIDATES = ("truth", "unchanged", "scaled", "level", "initialized", "graded")
TERMS = ("dis", "smo", "str", "pos", "fix", "cur", "seam")


def scaled_on_mesh(mesh, param, base, sx: float, sy: float) -> np.ndarray:
    uv = np.asarray(mesh.uv_cm, dtype=float).copy()
    vp = np.asarray(mesh.vertex_panel)
    for k, name in enumerate(mesh.panel_names):
        o = base.panel(name).outline_cm
        c = 0.5 * (o.min(axis=0) + o.max(axis=0))
        uv[vp == k] = c + (uv[vp == k] - c) * np.array([sx, sy])
    return param.theta_of(0.01 * uv)


def pattern_of(ctx, theta):
    """The pattern a grading stopped at theta would hand the user."""
    from seamfit.opt.output import adjusted_pattern
    return adjusted_pattern(ctx.base_pattern, ctx.mesh, 100.0 * ctx.param.pattern(theta)).refit.pattern


def run_case(data: str, garment: str, body: str, grade_kw: dict) -> dict:
    from accuracy_case import body_file, measurements_cm
    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings, algorithm1
    from seamfit.pattern import landmark_errors, load_pattern
    from seamfit.pattern.scale import proportional_ratios
    from seamfit.opt.prepare import prepare

    data = Path(data)
    row = {"garment": garment, "body": body, "candidates": {}}
    t0 = time.perf_counter()
    try:
        base = load_pattern(data / "patterns" / garment / "size06" / "pattern.json")
        truth = load_pattern(data / "patterns" / garment / body / "pattern.json")
        p0, p1 = body_file(data / "bodies", "size06"), body_file(data / "bodies", body)
        b0, b1 = load_body(p0), load_body(p1)
        ratios = proportional_ratios(base.garment_type, measurements_cm(data / "bodies", p0, b0),
                                     measurements_cm(data / "bodies", p1, b1))
        ctx = prepare(base, b0, b1, GradeSettings(**grade_kw, evaluate_base_pattern=False))
        thetas = {"unchanged": ctx.param.theta_bar,
                  "scaled": scaled_on_mesh(ctx.mesh, ctx.param, base, ratios["sx"], ratios["sy"])}
        if ctx.extra.get("theta_level") is not None:
            thetas["level"] = ctx.extra["theta_level"]
        try:
            thetas["truth"] = truth_on_mesh(ctx.mesh, ctx.param, base, truth)
        except ValueError as exc:
            row["candidates"]["truth"] = {"ok": False, "error": str(exc)}
        from seamfit.opt.fit import ease_report
        tri = ctx.mesh.triangles
        row["base_ease_cm"] = ease_report(ctx.base_body, ctx.xbar, tri)
        out = algorithm1(ctx)
        xs = {"initialized": out.x_start, "graded": out.x}
        thetas["initialized"], thetas["graded"] = out.theta_start, out.theta
        row["graded"] = {"converged": out.converged, "message": out.message, "iterations": out.iterations}
        for name, theta in thetas.items():
            x = xs.get(name)
            entry = {"ok": True}
            if x is None:
                res = ctx.exact(theta, ctx.xtilde, name)
                x = res.x
                entry["drape_converged"] = bool(res.converged)
            f, terms = ctx.objective.objective(x, theta)
            entry.update({"f": f, "terms": terms,
                          "landmark_max_cm": landmark_errors(pattern_of(ctx, theta), truth).max_cm,
                          # does the draft itself hold the base garment's ease on the new body?
                          "ease_cm": ease_report(ctx.target_body, x, tri)})
            row["candidates"][name] = entry
    except Exception as exc:  # noqa: BLE001 - a benchmark records, never stops
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["traceback"] = traceback.format_exc()[-1500:]
    row["seconds"] = time.perf_counter() - t0
    return row


def cmd_run(a) -> int:
    from bench_accuracy import discover, grade_kwargs
    pairs = discover(a.data, "size06", a.garments.split(",") if a.garments else None,
                     a.bodies.split(",") if a.bodies else None)
    rows = []
    os.environ["OMP_NUM_THREADS"] = "1"
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        futs = {pool.submit(run_case, str(a.data), g, b, grade_kwargs(a, g)): (g, b) for g, b in pairs}
        for fut in as_completed(futs):
            r = fut.result()
            rows.append(r)
            c = r["candidates"]
            msg = r.get("error") or "  ".join(f"{k} f={v['f']:.3g} lm={v['landmark_max_cm']:.2f}"
                                             for k, v in c.items() if v.get("ok"))
            print(f"{r['garment']}/{r['body']} ({r['seconds']:.0f} s): {msg}", flush=True)
            a.out.write_text(json.dumps({"command": " ".join(sys.argv), "cases": rows}, indent=1) + "\n")
    return 0


def _ease_table(rows, med) -> list[str]:
    """Median |ease on the target - the base garment's ease on the base body| per level and
    candidate: how far each pattern, the drafts' own included, is from holding the ease."""
    from accuracy_case import EASE_LEVELS, ease_errors
    rows = [r for r in rows if r.get("base_ease_cm")]
    if not rows or not any("ease_cm" in e for r in rows for e in r["candidates"].values()):
        return []
    out = ["", "## Ease held at the tape-measure levels", "",
           "Median over the cases of |ease on the target - the base garment's ease on the base body| "
           "(cm; garment tape girth minus body tape girth at the body's level), and in brackets the "
           "number of cases where the garment reaches that level.", "",
           "| candidate | " + " | ".join(EASE_LEVELS) + " |", "|---|" + "---:|" * len(EASE_LEVELS)]
    for c in CANDIDATES:
        per = {k: [] for k in EASE_LEVELS}
        for r in rows:
            e = r["candidates"].get(c, {})
            if e.get("ok") and e.get("ease_cm"):
                for k, v in ease_errors(r["base_ease_cm"], e["ease_cm"])["levels"].items():
                    per[k].append(v)
        if any(per.values()):
            out.append(f"| {c} | " + " | ".join(f"{med(v):.2f} ({len(v)})" if v else "-" for v in per.values()) + " |")
    return out


def cmd_report(a) -> int:
    d = json.loads(a.results.read_text())
    rows = sorted(d["cases"], key=lambda r: (r["garment"], r["body"]))
    ok = [r for r in rows if "error" not in r and r["candidates"].get("truth", {}).get("ok")
          and r["candidates"].get("graded", {}).get("ok")]
    lines = ["# Does the grading objective prefer the drafted pattern?", "",
             f"Generated by `tests/benchmarks/bench_objective_alignment.py report` from "
             f"`{a.results.name}` (command: `{d.get('command', '')}`).", "",
             "Every candidate pattern is put on the base mesh, draped on the target body from the grading's "
             "start (x-tilde) and scored with the grading objective f (default preset and start; R^fix and "
             "R^cur measure from the level-scaled start) term by term. *truth* is the pattern the drafting "
             "system made for the target body, each boundary vertex moved to the same fraction of the same "
             "edge; its landmark error is what that mapping costs. lm: max landmark error against the truth, "
             "cm.", ""]
    n = len(ok)
    lower = sum(r["candidates"]["truth"]["f"] < r["candidates"]["graded"]["f"] for r in ok)
    lines += [f"**{n} cases** with the truth on the mesh ({len(rows) - n} without: the drafting rules changed "
              f"the panel's edges, or the case failed). f(truth) < f(graded) in **{lower}**; "
              f"f(truth) > f(graded) in **{n - lower}**.", ""]
    med = lambda xs: st.median(xs) if xs else float("nan")  # noqa: E731
    lines += ["## Median over those cases", "",
              "| candidate | f | " + " | ".join(TERMS) + " | lm cm |", "|---|" + "---:|" * (len(TERMS) + 2)]
    for c in CANDIDATES:
        es = [r["candidates"][c] for r in ok if r["candidates"].get(c, {}).get("ok")]
        if not es:
            continue
        lines.append(f"| {c} | {med([e['f'] for e in es]):.3g} | "
                     + " | ".join(f"{med([e['terms'].get(t, 0.0) for e in es]):.3g}" for t in TERMS)
                     + f" | {med([e['landmark_max_cm'] for e in es]):.2f} |")
    lines += _ease_table(ok, med)
    lines += ["", "## Per case", "", "| garment | body | " + " | ".join(f"f {c} (lm)" for c in CANDIDATES)
              + " | largest term gap truth - graded |", "|---|---|" + "---|" * (len(CANDIDATES) + 1)]
    for r in rows:
        c = r["candidates"]
        cells = []
        for k in CANDIDATES:
            e = c.get(k, {})
            cells.append(f"{e['f']:.3g} ({e['landmark_max_cm']:.2f})" if e.get("ok") else "-")
        gap = "-"
        if c.get("truth", {}).get("ok") and c.get("graded", {}).get("ok"):
            diffs = {t: c["truth"]["terms"].get(t, 0) - c["graded"]["terms"].get(t, 0) for t in TERMS}
            t = max(diffs, key=diffs.get)
            gap = f"{t} {diffs[t]:+.3g}"
        lines.append(f"| {r['garment']} | {r['body']} | " + " | ".join(cells) + f" | {gap} |")
    write_page(a.docs / "objective_alignment.md", lines, a.notes, "Reading")
    return 0


def main(argv=None) -> int:
    cli = Commands()
    r = cli.add_run(cmd_run)
    add_sweep(r)
    r.add_argument("--preset", default="auto")
    r.add_argument("--start", default=None)
    r.add_argument("--edge-length", type=float, default=3.0)
    r.add_argument("--sdf-spacing", type=float, default=None)
    r.add_argument("--max-iterations", type=int, default=128)
    r.add_argument("--checkpoint-every", type=int, default=None)
    r.add_argument("--inner-iterations", type=int, default=None)
    r.add_argument("--time-budget", type=float, default=100.0)
    r.add_argument("--seam", type=float, default=None)
    cli.add_report(cmd_report, nargs=None, notes="markdown appended as 'Reading'")
    return cli.main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
