"""Grading on the GPU against the CPU: the same grading (GarmentCode's pencil skirt, size 6
to size 10) at several mesh sizes, its simulations on each device, with the loop's time
split into simulation (inexact steps and exact checkpoints), gradient (costs, adjoint
factorization and solve, df/dp) and objective evaluations, and the two results compared.

    # on a machine with a GPU (results.json rewritten after every run):
    PYTHONPATH=native/python python tests/benchmarks/bench_grade_device.py run --out OUT
    # docs/grade_device_results.md and its plot from one or more results.json:
    PYTHONPATH=native/python python tests/benchmarks/bench_grade_device.py report OUT/results.json
    # the paper's Fig. 10: objective against time for S = 1, 2, 4, 8 simulator iterations
    # per outer iteration, on each device (curves.json and docs/img/grade_s_curves.png):
    PYTHONPATH=native/python python tests/benchmarks/bench_grade_device.py curves --out OUT --devices cpu cuda

Per size the GPU runs first; its base drape is cached (the cache key leaves the device
out), so the CPU run starts from the same x-bar and both loops do the same work. The base
drape's time is reported for the run that made it.
"""
from __future__ import annotations

import contextlib
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))

from seamfit.fileio import atomic_write_text  # noqa: E402
from seamfit.opt.grade import GradeSettings  # noqa: E402
from bench_cli import DOCS, Commands  # noqa: E402
from doc_page import table  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import measure_switches  # noqa: E402

SAMPLES = ROOT / "sample_files"
PATTERN = SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json"
B0 = SAMPLES / "bodies" / "women_size06.obj"
B1 = SAMPLES / "bodies" / "women_size10.obj"


# The report's device names of the loop's parts, in the table's words.
PART_NAMES = (("simulation", "sim, rest state"), ("parametrization", "p(theta)"), ("adjoint", "adjoint, df/dp"),
              ("costs", "costs"), ("regularizers", "R, P^-1"), ("seam", "R^seam"))


def gpu_parts(report: dict):
    """What of the loop ran on the GPU, from the grading report's `devices`."""
    if report["device"] != "cuda":
        return None
    dev = report.get("devices") or {}
    return ", ".join(name for key, name in PART_NAMES if dev.get(key) == "cuda")


def grade_once(edge_cm: float, device: str, args) -> dict:
    from seamfit.body import load_body
    from seamfit.opt.grade import grade
    from seamfit.pattern import load_pattern
    from seamfit.sim import SimSettings

    settings = GradeSettings(edge_length_cm=edge_cm, max_outer_iterations=args.max_iterations,
                             sdf_spacing=args.sdf_spacing, sdf_region=args.sdf_region,
                             adjoint_forcing=args.adjoint_forcing,
                             checkpoint_every=args.checkpoint_every, device=device,
                             evaluate_base_pattern=False, time_budget_s=args.time_budget)
    sim_settings = SimSettings(max_seconds=args.stage_seconds,
                               **({"rho_max": args.rho_max} if args.rho_max else {}))
    t0 = time.perf_counter()
    with contextlib.ExitStack() as switches:
        if args.host_state:
            switches.enter_context(measure_switches.host_state())
        if args.accept_unsettled_base:
            switches.enter_context(measure_switches.accept_unsettled_base())
        res = grade(load_pattern(args.pattern), load_body(B0), load_body(B1), settings, sim_settings=sim_settings)
    r = res.report
    return {"garment": args.pattern.parent.parent.name, "edge_length_cm": edge_cm, "sdf_spacing_mm": 1000 * args.sdf_spacing, "device": r["device"],
            "sdf": r.get("sdf"),
            "adjoint_forcing": args.adjoint_forcing,
            "state_on_gpu": r.get("state_on_gpu"),
            "rho_max": sim_settings.rho_max,
            "triangles": r["mesh"]["triangles"],
            "vertices": r["mesh"]["vertices"], "wall_s": time.perf_counter() - t0,
            "seconds_total": r["seconds_total"], "seconds_precompute": r["seconds_precompute"],
            "seconds_loop": r["seconds_loop"], "seconds_per_iteration": r["seconds_per_iteration"],
            "split": r["seconds_loop_split"], "base_drape": r["base_drape"],
            "outer_iterations": r["outer_iterations"], "outer_iterations_done": r["outer_iterations_done"],
            "objective_initial": r["objective_initial"], "objective_final": r["objective_final"],
            "objective_reduction": r["objective_reduction"], "converged": r["converged"],
            "message": r["message"], "drape": r["drape"], "adjoint": r.get("adjoint"),
            "devices": r.get("devices"), "gpu_parts": gpu_parts(r),
            # the exact checkpoints (accepted or not) against loop time: how soon a reduction is reached
            "exact_history": [[t, f] for t, f, e in zip(res.history["seconds"], res.history["objective"],
                                                         res.history["exact"]) if e],
            "uv_cm": res.uv_cm.tolist()}


def cmd_run(args) -> int:
    import numpy as np

    args.out.mkdir(parents=True, exist_ok=True)
    meta = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                       f"Python {platform.python_version()}", "command": " ".join(sys.argv),
            "max_iterations": args.max_iterations, "checkpoint_every": args.checkpoint_every,
            "threads": os.environ.get("OMP_NUM_THREADS", "all")}
    try:
        from seamfit import _native
        meta["gpu"] = str(_native.core().cuda_device_name(0))
    except Exception as exc:  # no GPU: the CPU rows alone
        meta["gpu"] = f"none ({exc})"
    rows = []
    for edge in args.edges:
        uv = {}
        for device in args.devices:
            if device == "cpu" and edge < args.cpu_min_edge:
                continue
            try:
                row = grade_once(edge, device, args)
            except Exception as exc:  # recorded, not fatal: the other sizes still run
                row = {"edge_length_cm": edge, "device": device, "error": f"{type(exc).__name__}: {exc}"}
            uv[device] = np.asarray(row.pop("uv_cm", []))
            if len(uv) == 2 and all(len(u) for u in uv.values()):
                a, b = uv.values()
                row["pattern_difference_mm"] = float(np.max(np.linalg.norm(a - b, axis=1)) * 10.0)
            rows.append(row)
            atomic_write_text(args.out / "results.json", json.dumps({"meta": meta, "runs": rows}, indent=1))
            print(json.dumps({k: v for k, v in row.items() if k not in ("base_drape", "drape")}), flush=True)
    return 0


def adjoint_s(split: dict) -> float:
    """The adjoint's seconds of a loop's split: the CPU's factorizations and solves, or MINRES."""
    return split["factorizations"] + split.get("adjoint_solves", 0.0)


def curves_table(runs: list, loop: str = ".0f") -> str:
    """The table of a curves run, a row per device and S (``loop``: the format of its seconds)."""
    return table(["device", "S", "triangles", "loop s", "outer iterations done", "backtracks", "final objective"],
                 [[r["device"], str(r["S"]), f"{r['triangles']:,}", format(r["seconds_loop"], loop),
                   str(r["outer_iterations_done"]), str(r["backtracks"]), f"{r['objective_final']:.3f}"] for r in runs],
                 "lrrrrrr")


def cmd_report(args) -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs, metas = [], []
    for path in args.results:
        d = json.loads(path.read_text())
        metas.append(d["meta"])
        runs += d["runs"]
    ok = [r for r in runs if "error" not in r]
    lines = ["# Grading with its simulations on the GPU", "",
             "Generated by `tests/benchmarks/bench_grade_device.py` (GarmentCode pencil skirt, size 6 to size "
             "10, default strengths). Runs: "
             + "; ".join(f"`{m['command']}` ({m['machine']}, GPU {m['gpu']})" for m in metas) + ".", "",
             "SDF: the bodies' field spacing. Adjoint forcing: MINRES stops at max(1e-8, forcing x the "
             "state's relative residual) at inexact states (0: 1e-8 everywhere).", "",
             "Gradient: costs, adjoint solve and df/dp; adjoint: on the CPU the sparse LDL^T "
             "factorizations and solves, on the GPU MINRES (with its block setup); MINRES iterations per "
             "solve, and how many solves stopped at the iteration budget at an inexact state (kept) or "
             "fell back to the CPU at an equilibrium state.", "",
             "State: where theta and x live between exact checkpoints on the GPU (GPU: DeviceArrays; host: NumPy "
             "arrays, each GPU piece copying in and out; rows before the GPU state existed are host).", "",
             "| triangles | device (on the GPU) | state | SDF mm | adjoint forcing | base drape s | loop s | per outer iteration s "
             "| simulation s | gradient s | adjoint s | MINRES iterations per solve (kept at budget / fallbacks) "
             "| objective s | outer iterations accepted / done | objective reduction | pattern difference mm |",
             "|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(ok, key=lambda r: (r["triangles"], r["device"])):
        sp = r["split"]
        bd = r["base_drape"]
        adj = r.get("adjoint") or {}
        minres = (f"{adj['minres_iterations'] / max(adj['solves'], 1):,.0f} ({adj.get('truncated', 0)} / "
                  f"{adj.get('gpu_fallbacks', 0)})" if "minres_iterations" in adj else "-")
        forcing = adj.get("inexact_forcing", r.get("adjoint_forcing", 0.0)) if r["device"] == "cuda" else None
        lines.append(
            f"| {r['triangles']:,} | {r['device']}{' (' + r['gpu_parts'] + ')' if r.get('gpu_parts') else ''} | "
            f"{'-' if r['device'] != 'cuda' else ('GPU' if r.get('state_on_gpu') else 'host')} | "
            f"{r.get('sdf_spacing_mm', 2.5):g} | "
            f"{'-' if forcing is None else format(forcing, 'g')} | "
            f"{'cached' if bd.get('cached') else format(bd['seconds'], '.1f')}"
            f"{' (unsettled, residual ' + format(bd['residual'], '.2g') + ')' if bd.get('converged') is False else ''} | "
            f"{r['seconds_loop']:.1f} | {r['seconds_per_iteration']:.3f} | {sp['simulation']:.1f} | "
            f"{sp['gradient']:.1f} | {adjoint_s(sp):.1f} | {minres} | "
            f"{sp['objective']:.1f} | {r['outer_iterations']} / "
            f"{r['outer_iterations_done']} | {100 * r['objective_reduction']:.1f} % | "
            f"{format(r['pattern_difference_mm'], '.2f') if 'pattern_difference_mm' in r else '-'} |")
    for r in runs:
        if "error" in r:
            lines.append(f"\n* {r['edge_length_cm']} cm on {r['device']}: {r['error']}")
    fig, ax = plt.subplots(figsize=(7, 4))
    for dev, mk in (("cpu", "o"), ("cuda", "s")):
        rr = sorted([r for r in ok if r["device"] == dev], key=lambda r: r["triangles"])
        if not rr:
            continue
        tri = [r["triangles"] for r in rr]
        ax.plot(tri, [r["split"]["simulation"] / max(r["outer_iterations_done"], 1) for r in rr], mk + "-",
                label=f"{dev}: simulation")
        ax.plot(tri, [r["split"]["gradient"] / max(r["outer_iterations_done"], 1) for r in rr], mk + "--",
                label=f"{dev}: gradient")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("triangles")
    ax.set_ylabel("seconds per outer iteration")
    ax.set_title("Grading loop: where the time goes")
    ax.legend()
    fig.tight_layout()
    img = args.docs / "img" / "grade_device_split.png"
    img.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(img, dpi=110)
    lines += ["", f"![seconds per outer iteration](img/{img.name})", ""]
    if args.curves:
        cdata = json.loads(args.curves.read_text())
        cur = cdata["runs"]
        plot_curves(cur, args.docs)
        cmetas = cdata.get("metas") or ([cdata["meta"]] if "meta" in cdata else [])
        lines += ["## Objective against time, S = 1, 2, 4, 8", "",
                  f"From `bench_grade_device.py curves` ({args.curves.name}): the same grading with S simulator "
                  "iterations per outer iteration (a backtrack doubles it, accepted checkpoints halve it back), objective at the accepted exact "
                  "checkpoints against loop time, as the paper's Fig. 10."
                  + "".join(f" {', '.join(m.get('devices', []) or ['cpu'])} on {m['machine']}"
                            f"{', ' + m['gpu'] if m.get('gpu') else ''}: `{m['command']}`." for m in cmetas), ""]
        lines += [curves_table(cur), "", "![objective against time](img/grade_s_curves.png)", ""]
    atomic_write_text(args.docs / "grade_device_results.md", "\n".join(lines) + "\n")
    print(f"wrote {args.docs / 'grade_device_results.md'} and {img}")
    return 0


def plot_curves(runs, docs: Path, name: str = "grade_s_curves.png") -> Path:
    """The paper's Fig. 10 for these runs: (f - f*) / (f0 - f*) at the accepted checkpoints
    against loop time (log axes: the devices are an order of magnitude apart), as docs/img/NAME."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f_star = min(min(f for _, f in r["checkpoints"]) for r in runs)
    fig, ax = plt.subplots(figsize=(7, 4))
    for r in runs:
        pts = [(t, f) for t, f in r["checkpoints"] if t > 0.05]  # the start state sits at t = 0
        f0 = r["checkpoints"][0][1]
        err = [max((f - f_star) / (f0 - f_star), 1e-6) for _, f in pts]
        ax.plot([t for t, _ in pts], err, "o-" if r["device"] == "cpu" else "s--", ms=3,
                label=f"{r['device']}, S = {r['S']}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("seconds in the loop")
    ax.set_ylabel("(f - f*) / (f0 - f*)")
    ax.set_title(f"Objective against time, {runs[0]['triangles']:,} triangles")
    ax.legend(ncol=2, fontsize=8)
    fig.tight_layout()
    img = docs / "img" / name
    img.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(img, dpi=110)
    plt.close(fig)
    return img


def cmd_ncu_target(args) -> int:
    """A grading's preparation, then the GPU parts of a few outer iterations outside the
    simulator's and MINRES's own kernels (measured in gpu_results.md and
    adjoint_gpu_results.md): a new pattern's rest state, p(theta) and its adjoint, the
    inside-body check, the costs and (df/dp)^T lam."""
    import numpy as np
    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings
    from seamfit.opt.prepare import prepare
    from seamfit.pattern import load_pattern

    ctx = prepare(load_pattern(PATTERN), load_body(B0), load_body(B1),
                  GradeSettings(edge_length_cm=args.edge, device="cuda", evaluate_base_pattern=False))
    sim, param, gpu = ctx.sim, ctx.param, ctx.sim.cuda()
    x, _ = sim.iterate(ctx.xtilde, 2)
    for r in range(args.reps):
        theta = param.theta_bar * (1.0 + 1e-3 * (r + 1))
        p = param.pattern(theta)
        sim.set_pattern(p)
        gpu.sync()
        gpu.force(x)                                   # the inside check, then a force evaluation
        _, _, gx, gp = ctx.costs.evaluate(x, p)
        g = gpu.dfdp_T(x, np.asarray(gx).reshape(-1, 3))
        param.adjoint(np.asarray(gp) + g)
    return 0


def cmd_ncu_report(args) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_adjoint_gpu import ncu_table
    where = {"RestArgs": "rest state", "k_sum_parts": "rest state", "DenseRows": "p(theta)", "k_dtheta": "p(theta)",
             "k_scatter_pattern": "p(theta)", "k_gather_rows": "adjoint of p(theta)",
             "k_scatter_theta": "adjoint of p(theta)", "DevModel": "inside check", "Args": "costs",
             "k_partial": "costs", "Arrays": "(df/dp)^T lam"}
    lines = ["# The outer iteration's other kernels under Nsight Compute", "",
             "Generated by `tests/benchmarks/bench_grade_device.py ncu-report` from "
             f"`ncu --clock-control none --csv --metrics ... bench_grade_device.py ncu-target --edge 0.45` "
             f"({args.csv.name}; GarmentCode pencil skirt, 59,504 triangles, on an H100). The kernels of a new "
             "pattern (its rest state and p(theta)), the inside-body check, the fitting costs and (df/dp)^T lam; the "
             "simulator's iteration and the adjoint's MINRES are in [gpu_results.md](gpu_results.md) and "
             "[adjoint_gpu_results.md](adjoint_gpu_results.md). Medians over the profiled launches; ncu flushes "
             "the caches between its passes, so DRAM figures are cold-cache (in the loop these arrays stay in "
             "the 50 MB L2).", "",
             "| part | kernel | grid x block | time us | DRAM read MB | DRAM % of peak | L2 MB | L2 % of peak "
             "| warps active % |", "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for k in ncu_table(args.csv, keep_args=True):
        name, _, arg = k["kernel"].partition("(")
        arg = arg.rstrip(")")
        part = where.get(arg, where.get(name, "-"))
        label = name if ("," in arg or not arg) else f"{name} ({arg})"
        lines.append(f"| {part} | {label} | {k['grid']} x {k['block']} | {k['time_us']:.1f} | {k['dram_read_mb']:.2f} | "
                     f"{k['dram_pct']:.0f} | {k['l2_mb']:.2f} | {k['l2_pct']:.0f} | {k['warps_pct']:.0f} |")
    atomic_write_text(args.docs / "grade_device_kernels.md", "\n".join(lines) + "\n")
    print(f"wrote {args.docs / 'grade_device_kernels.md'}")
    return 0


def cmd_curves(args) -> int:
    """Objective at the exact checkpoints against loop time, one run per S (a backtrack
    doubles it and accepted checkpoints halve it back, as in Algorithm 1), plotted as the paper's relative error
    (f - f*) / (f0 - f*), f* the lowest final objective of all runs."""
    from seamfit.body import load_body
    from seamfit.opt.grade import grade
    from seamfit.pattern import load_pattern

    args.out.mkdir(parents=True, exist_ok=True)
    runs, metas = [], []
    for prev in args.merge or []:  # runs measured elsewhere (e.g. the CPU half on another machine)
        d = json.loads(prev.read_text())
        runs += d["runs"]
        metas += d.get("metas", [d["meta"]] if "meta" in d else [])
    for device in args.devices:
        for S in args.S:
            settings = GradeSettings(edge_length_cm=args.edge, max_outer_iterations=args.max_iterations,
                                     checkpoint_every=args.checkpoint_every, inner_iterations=S,
                                     min_inner_iterations=S, device=device, evaluate_base_pattern=False)
            res = grade(load_pattern(PATTERN), load_body(B0), load_body(B1), settings)
            h, r = res.history, res.report
            # accepted checkpoints: a backtrack's rejected one is undone, so the curve is the
            # running minimum of the exact objectives
            pts, best = [], float("inf")
            for t, f, e in zip(h["seconds"], h["objective"], h["exact"]):
                if e:
                    best = min(best, f)
                    pts.append((t, best))
            runs.append({"device": r["device"], "S": S, "triangles": r["mesh"]["triangles"],
                         "seconds_loop": r["seconds_loop"], "objective_final": r["objective_final"],
                         "outer_iterations_done": r["outer_iterations_done"], "backtracks": r["backtracks"],
                         "checkpoints": pts})
            print(json.dumps({k: v for k, v in runs[-1].items() if k != "checkpoints"}), flush=True)
            meta = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                               f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'all')}",
                    "devices": args.devices, "command": " ".join(sys.argv)}
            try:
                from seamfit import _native
                if "cuda" in args.devices:
                    meta["gpu"] = str(_native.core().cuda_device_name(0))
            except Exception:
                pass
            atomic_write_text(args.out / "curves.json",
                              json.dumps({"metas": metas + [meta], "runs": runs}, indent=1))
    img = plot_curves(runs, args.docs)
    print(f"wrote {args.out / 'curves.json'} and {img}")
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    r = cli.add_run(cmd_run)
    r.add_argument("--pattern", type=Path, default=PATTERN,
                   help="the base pattern, graded from women_size06 to women_size10 (default: the pencil skirt)")
    r.add_argument("--edges", type=float, nargs="+", default=[1.1, 0.64, 0.45],
                   help="mesh edge lengths in cm (default: about 10K, 30K and 60K triangles)")
    r.add_argument("--devices", nargs="+", default=["cuda", "cpu"])
    r.add_argument("--cpu-min-edge", type=float, default=0.0, help="no CPU run below this edge length")
    r.add_argument("--max-iterations", type=int, default=32)
    r.add_argument("--checkpoint-every", type=int, default=16)
    r.add_argument("--time-budget", type=float, default=0.0, help="seconds per grading (default none)")
    r.add_argument("--stage-seconds", type=float, default=120.0, help="time budget per drape stage")
    r.add_argument("--sdf-spacing", type=float, default=0.0025, help="body SDF spacing in metres")
    r.add_argument("--sdf-region", choices=("auto", "body", "garment"), default="auto",
                   help="body SDFs over the whole body, cut to the garment's height band, or auto (whole body "
                        "unless its grid is over the builder's node limit)")
    r.add_argument("--adjoint-forcing", type=float, default=GradeSettings.adjoint_forcing,
                   help="GPU adjoint tolerance at inexact states: max(1e-8, F * residual) (default: the grading's)")
    r.add_argument("--host-state", action="store_true",
                   help="the loop on host arrays, not GPU state between checkpoints (to measure what it saves)")
    r.add_argument("--accept-unsettled-base", action="store_true",
                   help="time the grading even when the base drape does not settle (its row says so)")
    r.add_argument("--rho-max", type=float, default=0.0,
                   help="upper bound of the Chebyshev rho (0: the simulator's default)")
    c = cli.add("curves", cmd_curves)
    c.add_argument("--out", type=Path, required=True)
    c.add_argument("--devices", nargs="+", default=["cpu"])
    c.add_argument("--S", type=int, nargs="+", default=[1, 2, 4, 8])
    c.add_argument("--edge", type=float, default=1.1, help="mesh edge length in cm (default 1.1: about 10K triangles)")
    c.add_argument("--max-iterations", type=int, default=64)
    c.add_argument("--checkpoint-every", type=int, default=8)
    c.add_argument("--docs", type=Path, default=DOCS)
    c.add_argument("--merge", type=Path, nargs="*", help="curves.json files whose runs join the plot")
    t = cli.add("ncu-target", cmd_ncu_target, help="the GPU parts of a few outer iterations, for ncu")
    t.add_argument("--edge", type=float, default=0.45)
    t.add_argument("--reps", type=int, default=3)
    k = cli.add("ncu-report", cmd_ncu_report, help="a markdown table of ncu --csv counters of ncu-target")
    k.add_argument("csv", type=Path)
    k.add_argument("--docs", type=Path, default=DOCS)
    q = cli.add_report(cmd_report)
    q.add_argument("--curves", type=Path, default=None, help="curves.json of a curves run, tabled with its plot")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
