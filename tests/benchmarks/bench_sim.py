"""Simulator benchmark: time against residual for Chebyshev-accelerated gradient
descent and Newton, on a few garments at two mesh resolutions, plus (with
--sweep) the full drape of every shared pattern on its own body.

    PYTHONPATH=native/python python tests/benchmarks/bench_sim.py run --out OUT.json [--quick] [--sweep DATA_DIR]
    PYTHONPATH=native/python python tests/benchmarks/bench_sim.py report OUT.json

``run`` writes the numbers to OUT.json (with each convergence run's residual history,
thinned to at most HISTORY_POINTS points), with --sweep also docs/img/drapes.png, then
reports, and prints the tables; ``report`` rewrites docs/simulator_results.md and draws
docs/img/sim_convergence.png from OUT.json alone (the drapes behind drapes.png are not
kept). --docs names another folder for the page and pictures. Each case is
meshed, dressed and sewn once (gravity off, Chebyshev); both solvers then settle
the same sewn state under gravity, so the curves compare the solvers, not the
dressing. Timings depend on the machine and its load; the report says which
machine and how many threads.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))

from seamfit.body import build_sdf, load_body  # noqa: E402
from seamfit.mesh import build_sewn_mesh  # noqa: E402
from seamfit.pattern import load_pattern  # noqa: E402
from seamfit.sim import Fabric, SimSettings, Simulator  # noqa: E402
from seamfit.sim.dressing import initial_positions  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cli import Commands  # noqa: E402

CASES = [("gc_pencil_skirt", "size06"), ("fs_bodice", "size06"), ("gc_circle_skirt", "size06")]
BODY_FILE = {"man_medium": "men_medium"}
HISTORY_POINTS = 200  # the most points of a residual history OUT.json keeps


def body_path(root: Path, body_id: str) -> Path:
    return root / "bodies" / f"{BODY_FILE.get(body_id, 'women_' + body_id)}.obj"


def setup(root: Path, garment: str, body_id: str, edge_cm: float, settings: SimSettings):
    pattern = load_pattern(root / "patterns" / garment / body_id / "pattern.json")
    mesh = build_sewn_mesh(pattern, edge_cm)
    body = load_body(body_path(root, body_id))
    sdf = build_sdf(body)
    x0, _ = initial_positions(mesh, pattern, sdf)
    return pattern, mesh, body, sdf, x0, Simulator(mesh, sdf, Fabric(), settings)


def thin_history(history: dict[str, list]) -> dict[str, list]:
    """A solver's history (iteration, seconds, residual lists) as plain lists of at most
    HISTORY_POINTS evenly spaced samples, first and last kept, to 4 significant digits."""
    n = len(history["residual"])
    keep = sorted({int(i) for i in np.linspace(0, n - 1, min(n, HISTORY_POINTS))}) if n else []
    return {"iteration": [int(history["iteration"][i]) for i in keep],
            "seconds": [float(f"{history['seconds'][i]:.4g}") for i in keep],
            "residual": [float(f"{history['residual'][i]:.4g}") for i in keep]}


def convergence(root: Path, edges: list[float], budget_s: float, tol: float) -> list[dict]:
    rows = []
    for garment, body_id in CASES:
        for edge in edges:
            _, mesh, _, sdf, x0, sim = setup(root, garment, body_id, edge, SimSettings())
            sewn = sim.solve(x0, gravity_scale=0.0, tolerance=1e-2, max_iterations=3000)
            for method in ("chebyshev", "newton"):
                s = SimSettings(method=method, tolerance=tol, max_seconds=budget_s,
                                max_iterations=10**7 if method == "chebyshev" else 10**5,
                                history_every=20 if method == "chebyshev" else 1)
                sim2 = Simulator(mesh, sdf, Fabric(), s)
                res = sim2.solve(sewn.x)
                st = res.stages[0]
                per_it = res.seconds / max(res.iterations, 1)
                row = dict(garment=garment, body=body_id, edge_cm=edge, vertices=int(mesh.n_vertices),
                           triangles=int(len(mesh.triangles)), method=method, iterations=res.iterations,
                           seconds=res.seconds, residual=res.residual, converged=res.converged,
                           seconds_per_iteration=per_it,
                           ns_per_triangle_iteration=1e9 * per_it / len(mesh.triangles),
                           threads=int(sim2.core.threads), restarts=st.get("restarts", 0),
                           history=thin_history(res.history))
                rows.append(row)
                print(f"{garment:16s} {edge:4.1f} cm {mesh.n_vertices:6d} v {len(mesh.triangles):6d} t  {method:9s} "
                      f"{res.iterations:7d} it {res.seconds:7.1f} s  residual {res.residual:.2e}  "
                      f"{row['ns_per_triangle_iteration']:7.0f} ns/tri/it", flush=True)
    return rows


def sweep(root: Path, budget_s: float, only: list[str] | None, bodies_only: list[str] | None,
          base_only: list[str] | None, pictures: list) -> list[dict]:
    index = json.loads((root / "patterns" / "index.json").read_text())
    base = index.get("base_body", "size06")
    rows = []
    for garment, bodies in sorted(index["garments"].items()):
        if (only or base_only) and garment not in (only or []) + (base_only or []):
            continue
        for body_id in sorted(bodies):
            if not body_path(root, body_id).exists() or (bodies_only and body_id not in bodies_only):
                continue
            if garment not in (only or []) and base_only and garment in base_only and body_id != base:
                continue
            t = time.perf_counter()
            try:
                _, mesh, body, _, x0, sim = setup(root, garment, body_id, 1.5, SimSettings(max_seconds=budget_s))
                res = sim.drape(x0)
                pictures.append((f"{garment} / {body_id}", res.x, mesh.triangles, mesh.triangle_panel,
                                 body.vertices, body.faces))
                row = dict(garment=garment, body=body_id, vertices=int(mesh.n_vertices),
                           triangles=int(len(mesh.triangles)), iterations=res.iterations, seconds=res.seconds,
                           residual=res.residual, converged=res.converged,
                           max_sewing_gap_mm=res.max_sewing_gap_mm, min_phi_mm=res.min_phi_mm,
                           threads=int(sim.core.threads),
                           stages=[{k: st[k] for k in ("stage", "iterations", "seconds", "residual", "message")}
                                   for st in res.stages])
            except Exception as exc:  # reported in the table, not hidden
                row = dict(garment=garment, body=body_id, error=f"{type(exc).__name__}: {exc}")
            row["wall_seconds"] = time.perf_counter() - t
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = sorted({(r["garment"], r["edge_cm"]) for r in rows}, key=lambda c: (c[0], -c[1]))
    garments = sorted({c[0] for c in cases})
    edges = sorted({c[1] for c in cases}, reverse=True)
    fig, axes = plt.subplots(len(edges), len(garments), figsize=(4.2 * len(garments), 3.3 * len(edges)),
                             squeeze=False)
    for i, e in enumerate(edges):
        for j, g in enumerate(garments):
            ax = axes[i][j]
            for r in rows:
                if r["garment"] == g and r["edge_cm"] == e:
                    ax.semilogy(r["history"]["seconds"], r["history"]["residual"], label=r["method"],
                                color="C0" if r["method"] == "chebyshev" else "C3")
                    tri = r["triangles"]
            ax.axhline(1e-3, color="grey", lw=0.8, ls="--")
            ax.set_title(f"{g}, {e:g} cm ({tri} triangles)", fontsize=9)
            ax.set_xlabel("seconds")
            ax.set_ylabel("relative residual |f|/|mg|")
            ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_md(path: Path, conv: list[dict], sw: list[dict], machine: str, command: str | None,
             commit: str | None) -> None:
    by = f"`{command or 'tests/benchmarks/bench_sim.py'}` on {machine}" + (f" at commit {commit}" if commit else "")
    lines = ["# Simulator results", "",
             f"Measured by {by}. Timings are wall-clock on a shared, "
             "loaded machine and vary by tens of percent between runs.", ""]
    if conv:
        lines += ["## Convergence: Chebyshev gradient descent against Newton", "",
                  "Same sewn start state for both; settle under gravity to the residual shown "
                  "(relative residual = |f| / |m g|).", "",
                  "![convergence](img/sim_convergence.png)", "",
                  "| garment | edge (cm) | vertices | triangles | method | iterations | seconds | residual | "
                  "s / iteration | ns / triangle / iteration | threads |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in conv:
            lines.append(f"| {r['garment']} | {r['edge_cm']:g} | {r['vertices']} | {r['triangles']} | {r['method']} | "
                         f"{r['iterations']} | {r['seconds']:.1f} | {r['residual']:.1e} | "
                         f"{r['seconds_per_iteration']:.4f} | {r['ns_per_triangle_iteration']:.0f} | {r['threads']} |")
        lines.append("")
    if sw:
        lines += ["## Dressing every shared pattern on its own body", "",
                  "`Simulator.drape` from the pattern's placement (FreeSewing hints wrapped around the body), "
                  "1.5 cm edges, defaults (tolerance 1e-3; time budget 300 s per stage). Stages: "
                  "sew / settle (Chebyshev) / polish (Newton), iterations and seconds each.", "",
                  "![drapes](img/drapes.png)", "",
                  "| garment | body | vertices | iterations | seconds | residual | converged | max seam gap (mm) | "
                  "min phi (mm) | stages |", "|---|---|---|---|---|---|---|---|---|---|"]
        for r in sw:
            if "error" in r:
                lines.append(f"| {r['garment']} | {r['body']} | | | | | error: {r['error']} | | | |")
            else:
                stages = ", ".join(f"{st['stage']} {st['iterations']} / {st['seconds']:.0f} s" for st in r["stages"])
                lines.append(f"| {r['garment']} | {r['body']} | {r['vertices']} | {r['iterations']} | "
                             f"{r['seconds']:.1f} | {r['residual']:.1e} | {'yes' if r['converged'] else 'no'} | "
                             f"{r['max_sewing_gap_mm']:.2f} | {r['min_phi_mm']:.2f} | {stages} |")
        lines.append("")
    path.write_text("\n".join(lines))


def cmd_run(args) -> int:
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs"
    if args.no_convergence:
        # keep the convergence rows of the last run (the report draws their plot again)
        conv = json.loads(args.out.read_text()).get("convergence", []) if args.out.exists() else []
    else:
        conv = convergence(args.data, [2.0] if args.quick else [2.0, 1.0], 30.0 if args.quick else args.budget,
                           args.tolerance)
    pictures: list = []
    sw = sweep(args.sweep, 60.0 if args.quick else 300.0, args.sweep_only, args.sweep_bodies, args.sweep_base,
               pictures) if args.sweep else []
    if pictures:
        from seamfit.sim.render import render_front_grid
        # one picture per garment, on the base body
        base = [item for item in pictures if item[0].endswith("/ size06")] or pictures
        render_front_grid(args.docs / "img" / "drapes.png", base)
    from bench_accuracy import git_commit
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(
        {"machine": machine, "commit": git_commit(), "command": " ".join(sys.argv), "convergence": conv,
         "sweep": sw}, indent=1))
    return cmd_report(argparse.Namespace(results=args.out, docs=args.docs))


def cmd_report(args) -> int:
    data = json.loads(args.results.read_text())
    conv = data["convergence"]
    if conv and all("history" in r for r in conv):  # data of earlier runs kept no histories
        plot(conv, args.docs / "img" / "sim_convergence.png")
    write_md(args.docs / "simulator_results.md", conv, data["sweep"], data["machine"], data.get("command"),
             data.get("commit"))
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    ap = cli.add_run(cmd_run)
    ap.add_argument("--docs", type=Path, default=ROOT / "docs", help="where the page and pictures go")
    ap.add_argument("--data", type=Path, default=ROOT / "sample_files", help="patterns/ and bodies/ root")
    ap.add_argument("--quick", action="store_true", help="one resolution, short budgets")
    ap.add_argument("--budget", type=float, default=120.0, help="seconds per solver run")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--sweep", type=Path, default=None, help="also drape every pattern under this data root")
    ap.add_argument("--sweep-only", nargs="*", default=None, help="garment ids for --sweep")
    ap.add_argument("--sweep-bodies", nargs="*", default=None, help="body ids for --sweep")
    ap.add_argument("--sweep-base", nargs="*", default=None, help="garment ids for --sweep, on the base body only")
    ap.add_argument("--no-convergence", action="store_true",
                    help="keep the convergence rows of the --out file (e.g. to add a sweep)")
    cli.add_report(cmd_report, nargs=None)
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
