"""The adjoint solve H lam = dF/dx: the CPU's sparse LDL^T against MINRES on the GPU,
time and gradient error, at a real grading state (GarmentCode's pencil skirt, size 6
graded to size 10, the unchanged pattern settled on the target body) per mesh size.

    # on a machine with a GPU:
    PYTHONPATH=native/python python tests/benchmarks/bench_adjoint_gpu.py run --out OUT
    # MINRES iterations alone at one size (plain garment state, random g), for timing
    # per iteration and for a profiler (ncu --clock-control none ... ncu-target):
    PYTHONPATH=native/python python tests/benchmarks/bench_adjoint_gpu.py ncu-target --edge 0.45
    # docs/adjoint_gpu_results.md (and docs/results/data/adjoint_gpu_results.json) from one or
    # more results.json:
    PYTHONPATH=native/python python tests/benchmarks/bench_adjoint_gpu.py report OUT/results.json

The gradient error is |g_gpu - g_cpu| / |g_cpu| of the pattern gradient
dF/dp + (df/dp)^T lam; the residual is |g - H lam| / |g| with the CPU's Hessian.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

# The grading case of the device benchmark (it also puts native/python on the path).
from bench_grade_device import B0, B1, PATTERN  # noqa: E402
from seamfit.fileio import atomic_write_text  # noqa: E402
from bench_cli import Commands  # noqa: E402


def one_size(edge_cm: float, args) -> dict:
    import numpy as np

    from seamfit.body import load_body
    from seamfit.opt.adjoint import AdjointSolver
    from seamfit.opt.grade import GradeSettings
    from seamfit.opt.prepare import prepare
    from seamfit.pattern import load_pattern
    from seamfit.sim import SimSettings

    settings = GradeSettings(edge_length_cm=edge_cm, device="cuda", evaluate_base_pattern=False)
    ctx = prepare(load_pattern(PATTERN), load_body(B0), load_body(B1), settings,
                  sim_settings=SimSettings(max_seconds=args.stage_seconds))
    t0 = time.perf_counter()
    res = ctx.exact(ctx.param.theta_bar, ctx.xtilde, "bench")
    row = {"edge_length_cm": edge_cm, "triangles": int(len(ctx.mesh.triangles)), "vertices": int(ctx.mesh.n_vertices),
           "drape": {"converged": bool(res.converged), "residual": float(res.residual),
                     "seconds": time.perf_counter() - t0}}
    x = res.x
    _, _, gx, gp = ctx.costs.evaluate(x, ctx.param.pattern(ctx.param.theta_bar))
    gx, gp = np.asarray(gx, dtype=float), np.asarray(gp, dtype=float)

    cpu = AdjointSolver(ctx.sim, device="cpu")
    t0 = time.perf_counter()
    cpu.factorize(x)
    t1 = time.perf_counter()
    lam_cpu = cpu.solve(gx)
    t2 = time.perf_counter()
    g_cpu = gp + ctx.sim.dfdp_T(x, lam_cpu.reshape(-1, 3))
    row["cpu"] = {"factorize_s": t1 - t0, "solve_s": t2 - t1, "lu_fallbacks": cpu.lu_fallbacks,
                  "threads": os.environ.get("OMP_NUM_THREADS", "all")}
    H = ctx.sim.hessian(x)
    shift = 1e-8 * float(np.mean(np.abs(H.diagonal())))
    gn = float(np.linalg.norm(gx))

    def residual(lam):
        return float(np.linalg.norm(gx.reshape(-1) - (H @ lam + shift * lam)) / gn)

    row["cpu"]["residual"] = residual(lam_cpu)
    row["gpu"] = []
    for tol in args.tolerances:
        gpu = AdjointSolver(ctx.sim, device="cuda", gpu_tolerance=tol, gpu_max_iterations=args.max_iterations)
        t0 = time.perf_counter()
        gpu.factorize(x)
        t1 = time.perf_counter()
        lam = gpu.solve(gx)
        t2 = time.perf_counter()
        rep = dict(gpu.last_report)
        g = gp + ctx.sim.dfdp_T(x, lam.reshape(-1, 3))
        # Warm start: the same system again from a lam 1 % off (a stand-in for the
        # previous outer iteration's).
        rng = np.random.default_rng(0)
        gpu._lam = lam.reshape(-1, 3) * (1 + 0.01 * rng.standard_normal(lam.shape).reshape(-1, 3))
        t3 = time.perf_counter()
        gpu.solve(gx)
        t4 = time.perf_counter()
        row["gpu"].append({"tolerance": tol, "setup_s": t1 - t0, "solve_s": t2 - t1, "iterations": rep["iterations"],
                           "converged": rep["converged"], "fallbacks": gpu.gpu_fallbacks,
                           "residual": residual(lam), "gradient_error": float(np.linalg.norm(g - g_cpu)
                                                                               / np.linalg.norm(g_cpu)),
                           "us_per_iteration": 1e6 * rep["seconds"] / max(rep["iterations"], 1),
                           "warm_iterations": gpu.last_report["iterations"], "warm_solve_s": t4 - t3})
        print(f"{row['triangles']:>7,} tri  tol {tol:.0e}: {rep['iterations']:>6} its "
              f"{t2 - t1:.3f} s (setup {t1 - t0:.3f} s), gradient error {row['gpu'][-1]['gradient_error']:.2e}, "
              f"warm {gpu.last_report['iterations']} its; CPU LDLT {row['cpu']['factorize_s']:.3f} + "
              f"{row['cpu']['solve_s']:.3f} s", flush=True)
    return row


def cmd_run(args) -> int:
    args.out.mkdir(parents=True, exist_ok=True)
    from seamfit import _native
    meta = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
            "gpu": str(_native.core().cuda_device_name(0)), "command": " ".join(sys.argv),
            "path": "persistent kernel"}
    rows = []
    for edge in args.edges:
        try:
            rows.append(one_size(edge, args))
        except Exception as exc:  # one size failing must not lose the others
            rows.append({"edge_length_cm": edge, "error": f"{type(exc).__name__}: {exc}"})
            print(f"edge {edge}: {rows[-1]['error']}", flush=True)
        atomic_write_text(args.out / "results.json", json.dumps({"meta": meta, "rows": rows}, indent=1))
    return 0


def cmd_ncu_target(args) -> int:
    """MINRES iterations at a garment state of one size, no base drape needed: the
    pencil skirt from its placement, settled for a while on the size 10 body."""
    import numpy as np

    from seamfit._native import core
    from seamfit.body import build_sdf, load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    from seamfit.sim import Fabric, SimSettings, Simulator

    mesh = build_sewn_mesh(load_pattern(PATTERN), edge_length_cm=args.edge)
    sim = Simulator(mesh, build_sdf(load_body(B1)), Fabric(), SimSettings(device="cuda"))
    res = sim.solve(np.asarray(mesh.x0, dtype=float), max_iterations=args.settle)
    gpu = sim.cuda()._gpu
    adj = core().CudaAdjoint(gpu)
    adj.set_state(gpu, res.x, False, 1e-8)
    g = np.random.default_rng(0).standard_normal(res.x.shape)
    out = {"triangles": int(len(mesh.triangles)), "vertices": int(mesh.n_vertices)}
    lams = {}
    for name, persistent in (("persistent", True), ("graph", False)):
        if args.only and name != args.only:
            continue
        adj.solve(gpu, g, None, 0.0, 64, persistent=persistent)  # warm-up (graph capture)
        lams[name], rep = adj.solve(gpu, g, None, 0.0, args.iterations, persistent=persistent)
        out["iterations"] = rep["iterations"]
        out[f"us_per_iteration_{name}"] = 1e6 * rep["seconds"] / max(rep["iterations"], 1)
    if len(lams) == 2:  # the two paths run the same arithmetic in the same order
        out["paths_identical"] = bool(np.array_equal(lams["persistent"], lams["graph"]))
    print(json.dumps(out), flush=True)
    return 0


def ncu_table(path: Path, keep_args: bool = False) -> list[dict]:
    """Per kernel, the medians of ncu's --csv metrics. keep_args: tell kernels of the same
    name apart by their parameter types (kernels of different files share names)."""
    import csv
    import statistics
    text = [ln for ln in path.read_text().splitlines() if ln.startswith('"')]
    per: dict = {}
    for r in csv.DictReader(text):
        name = r["Kernel Name"].split("(")[0].split("::")[-1].split("<")[0]
        if keep_args and "(" in r["Kernel Name"]:
            arg = r["Kernel Name"].split("(", 1)[1].rstrip(")").split("::")[-1].split("<")[0]
            name = f"{name}({arg})"
        k = per.setdefault(name, {"grid": r["Grid Size"].split(",")[0].strip("( "),
                                  "block": r["Block Size"].split(",")[0].strip("( ")})
        k.setdefault(r["Metric Name"], []).append(float(r["Metric Value"].replace(",", "")))
    out = []
    for name, k in per.items():
        med = {m: statistics.median(v) for m, v in k.items() if isinstance(v, list)}
        out.append({"kernel": name, "grid": k["grid"], "block": k["block"],
                    "time_us": med["gpu__time_duration.sum"] / 1e3,
                    "dram_read_mb": med["dram__bytes_read.sum"] / 1e6,
                    "dram_pct": med["dram__throughput.avg.pct_of_peak_sustained_elapsed"],
                    "l2_mb": med["lts__t_bytes.sum"] / 1e6,
                    "l2_pct": med["lts__throughput.avg.pct_of_peak_sustained_elapsed"],
                    "warps_pct": med["sm__warps_active.avg.pct_of_peak_sustained_active"]})
    return out


def cmd_report(args) -> int:
    rows, metas = [], []
    for p in args.results:
        d = json.loads(p.read_text())
        metas.append(d["meta"])
        rows += [{**r, "path": d["meta"].get("path", "persistent kernel")} for r in d["rows"] if "error" not in r]
    rows.sort(key=lambda r: r["triangles"])
    lines = ["# The adjoint solve: CPU LDL^T against GPU MINRES", "",
             "Generated by `tests/benchmarks/bench_adjoint_gpu.py report`; method in "
             "[gpu_backend.md](gpu_backend.md#the-adjoint-on-the-gpu).", ""]
    for m in metas:
        lines.append(f"- {m['gpu']}; host {m['machine']}; {m.get('path', 'persistent kernel')}. "
                     f"Command: `{m['command']}`")
    lines += ["", "GarmentCode pencil skirt, size 6 pattern on the size 10 body (settled). CPU: Eigen "
              "sparse LDL^T of the shifted exact Hessian, AMD ordering, one thread. GPU: MINRES with "
              "block-Jacobi preconditioner, cold start. Gradient error: of the pattern gradient against "
              "the CPU's. Residual: |g - H lam| / |g|. Warm: the same solve from a lam perturbed by 1 %.", "",
              "| triangles | CPU factorize + solve | tolerance | GPU path | GPU setup + solve | MINRES iterations | "
              "us / iteration | residual | gradient error | warm iterations |",
              "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        c = r["cpu"]
        for g in r["gpu"]:
            lines.append(f"| {r['triangles']:,} | {c['factorize_s']:.3f} + {c['solve_s']:.3f} s | "
                         f"{g['tolerance']:.0e} | {r['path']} | {g['setup_s']:.3f} + {g['solve_s']:.3f} s | "
                         f"{g['iterations']:,}"
                         f"{'' if g['converged'] else ' (budget)'} | {g['us_per_iteration']:.1f} | "
                         f"{g['residual']:.1e} | {g['gradient_error']:.1e} | {g['warm_iterations']:,} |")
    sizes = []
    if args.sizes:
        sizes = [json.loads(ln) for ln in args.sizes.read_text().splitlines() if ln.startswith("{")]
        lines += ["", "## Time per MINRES iteration against size", "",
                  "`bench_adjoint_gpu.py ncu-target --edge E` (2,000 iterations at a settled state, "
                  "one graph launch per 32 iterations, the host reading the state between launches):", "",
                  "| triangles | vertices | persistent kernel us | graph of 4 kernels us |", "|---:|---:|---:|---:|"]
        lines += [f"| {z['triangles']:,} | {z['vertices']:,} | "
                  f"{z.get('us_per_iteration_persistent', float('nan')):.1f} | "
                  f"{z.get('us_per_iteration_graph', z.get('us_per_iteration', float('nan'))):.1f} |"
                  for z in sorted(sizes, key=lambda z: z["triangles"])]
    kernels = [k for f in (args.ncu or []) for k in ncu_table(f)]
    if kernels:
        lines += ["", "## Kernels (Nsight Compute)", "",
                  "`ncu --clock-control none` on `ncu-target --edge 0.45` (59,504 triangles; "
                  f"{', '.join(f.name for f in args.ncu)}); medians over the profiled launches. ncu flushes the "
                  "caches between its passes, so DRAM bytes are cold-cache figures (in the solve the working "
                  "set stays in the 50 MB L2). The persistent kernel runs 32 iterations per launch; its row "
                  "is per launch.", "",
                  "| kernel | grid x block | time us | DRAM read MB | DRAM % of peak | L2 MB | L2 % of peak "
                  "| warps active |", "|---|---|---:|---:|---:|---:|---:|---:|"]
        for k in kernels:
            lines.append(f"| {k['kernel']} | {k['grid']} x {k['block']} | {k['time_us']:.1f} | "
                         f"{k['dram_read_mb']:.2f} | {k['dram_pct']:.0f} % | {k['l2_mb']:.1f} | {k['l2_pct']:.0f} % | "
                         f"{k['warps_pct']:.0f} % |")
    atomic_write_text(args.docs / "adjoint_gpu_results.md", "\n".join(lines) + "\n")
    data = args.docs / "results" / "data"  # the raw numbers beside the other benchmarks' data
    data.mkdir(parents=True, exist_ok=True)
    atomic_write_text(data / "adjoint_gpu_results.json",
                      json.dumps({"metas": metas, "rows": rows, "sizes": sizes, "kernels": kernels}, indent=1))
    print("\n".join(lines))
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    r = cli.add_run(cmd_run)
    r.add_argument("--edges", type=float, nargs="+", default=[1.1, 0.64])
    r.add_argument("--tolerances", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8])
    r.add_argument("--max-iterations", type=int, default=50000)
    r.add_argument("--stage-seconds", type=float, default=0.0, help="time budget per drape stage (0: none)")
    t = cli.add("ncu-target", cmd_ncu_target)
    t.add_argument("--edge", type=float, default=0.45)
    t.add_argument("--settle", type=int, default=2000, help="simulator iterations before the solve")
    t.add_argument("--iterations", type=int, default=2000)
    t.add_argument("--only", choices=("persistent", "graph"), help="time one path only (for a profiler)")
    q = cli.add_report(cmd_report)
    q.add_argument("--sizes", type=Path, help="the JSON lines of ncu-target runs (time per iteration)")
    q.add_argument("--ncu", type=Path, nargs="*", help="ncu --csv outputs of ncu-target runs")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
