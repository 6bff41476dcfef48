"""Exact solves on the GPU: Chebyshev alone against Chebyshev followed by Newton with
MINRES steps (seamfit.sim.cuda.CudaSimulator.newton), for the base pattern's drape on the
target body (GarmentCode's pencil skirt, size 6 to size 10) from the transferred garment
x-tilde: how far Chebyshev gets in a given number of iterations, and how many Newton
iterations (and MINRES iterations) take it from there to the exact tolerance.

    PYTHONPATH=native/python python tests/benchmarks/bench_newton_exact.py --edge 1.1 \\
        --chebyshev 10000 20000 --linear 2000 20000 --out OUT/newton_1.1.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_grade_device import B0, B1, PATTERN  # noqa: E402
from seamfit.fileio import atomic_write_text  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--edge", type=float, default=0.45, help="mesh edge length in cm")
    ap.add_argument("--chebyshev", type=int, nargs="+", default=[10000, 40000], help="Chebyshev iteration budgets")
    ap.add_argument("--linear", type=int, nargs="+", default=[2000, 20000], help="MINRES budgets per Newton step")
    ap.add_argument("--newton-iterations", type=int, default=80)
    ap.add_argument("--tolerance", type=float, default=1e-3)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)

    from seamfit.body import load_body
    from seamfit.opt.grade import GradeSettings
    from seamfit.opt.prepare import prepare
    from seamfit.pattern import load_pattern

    ctx = prepare(load_pattern(PATTERN), load_body(B0), load_body(B1),
                  GradeSettings(edge_length_cm=args.edge, device="cuda", evaluate_base_pattern=False))
    sim = ctx.sim
    sim.set_pattern(ctx.param.pattern(ctx.param.theta_bar))
    gpu = sim.cuda()
    out = {"edge": args.edge, "n_vertices": int(sim.n_vertices), "device": gpu.device_name,
           "command": " ".join(sys.argv[1:]) if argv is None else " ".join(argv), "runs": []}
    x0 = sim.project_outside(ctx.xtilde)[0]
    for n_cheb in args.chebyshev:
        t = time.perf_counter()
        xc, rc = gpu.solve(x0, settings=sim._settings(args.tolerance, n_cheb, "chebyshev"))
        t_cheb = time.perf_counter() - t
        for lin in args.linear:
            t = time.perf_counter()
            _, rn = gpu.newton(xc, settings=sim._settings(args.tolerance, args.newton_iterations, "newton"),
                               max_linear_iterations=lin)
            row = {"chebyshev": n_cheb, "cheb_iterations": rc["iterations"], "cheb_residual": rc["residual"],
                   "cheb_s": t_cheb, "max_linear": lin, "newton_iterations": rn["iterations"],
                   "linear_iterations": rn.get("linear_iterations"), "residual": rn["residual"],
                   "converged": rn["converged"], "newton_s": time.perf_counter() - t, "message": rn.get("message")}
            out["runs"].append(row)
            print(json.dumps(row), flush=True)
    atomic_write_text(args.out, json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
