"""docs/speed.md: how long a grading takes, on a CPU and on a GPU, gathered from the data the
other results pages are written from.

    python tests/benchmarks/speed_report.py report docs/results/data [--notes NOTES] [--docs OUT]

The page's text is tests/benchmarks/speed_notes.md (--notes). Each `<!-- name -->` in it is
what the report computes from the data folder's files named below: a table where it stands
on a line of its own, a measured number inline. What was measured comes from the data; the
settings a run was made with (sizes, budgets, cores), the machines, and the numbers no data
file holds (the grading command's wall times, the device calibration, the body fields'
build times, the paper's) are written in the notes, each beside the page it is quoted from.

``report`` writes docs/speed.md and docs/img/grade_s_curves_60k.png.
"""
from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

from bench_accuracy_time import reached
from bench_batch_scaling import vs_linear
from bench_cli import Commands
from bench_cuda import _threads, fastest, merge
from bench_gpu_share import vs_one
from bench_grade_device import adjoint_s, curves_table, plot_curves
from doc_page import fill, table
from seamfit.fileio import atomic_write_text

NOTES = Path(__file__).resolve().parent / "speed_notes.md"

# The data behind each part of the page, under the data folder.
LOOP = "grade_device/run_10k_30k.json"  # the grading loop on each device, 10K and 30K
DIRECT_60K = {"gpu_state": "grade_device/run_60k_forcing1e-2_device_state.json",
              "host_state": "grade_device/run_60k_forcing1e-2_host_state.json",
              "exact_adjoint": "grade_device/run_60k_forcing0_rho_max.json"}
BODICE_60K = "grade_device/run_60k_fs_bodice_device_state.json"
BY_SIZE = ("grade_device/run_10k_30k_60k_16_device_state.json", "grade_device/run_150k_sdf1.8mm_device_state.json",
           "grade_device/run_300k_sdf1.25mm_cropped_unsettled_device_state.json")
SIMULATOR = ("gpu_results/h200.json", "gpu_results/h200_cpu_rerun.json")
CHEBYSHEV = "simulator_results.json"
ADJOINT = "adjoint_gpu/run_persistent_1e-8.json"
ADJOINT_GRAPH = ("adjoint_gpu/run_10k.json", "adjoint_gpu/run_30k.json")
MINRES_SIZES = "adjoint_gpu/minres_sizes.jsonl"
DRAPES = ("base_drape/h100_cuda.json", "base_drape/h100_cuda_150k_sdf1.8mm.json",
          "base_drape/devbox_cpu_10k.json", "base_drape/devbox_cpu_30k.json")
ACCURACY_TIME = {"cpu": "accuracy_time.json", "cuda": "accuracy_time_gpu.json", "cpu_2cm": "accuracy_time_cpu_2cm.json"}
BUDGET_S = 30  # the run-time-against-error reading's moment
BATCH = ("batch_scaling_2rounds.json", "batch_scaling_6rounds.json")
SHARING = "gpu_sharing.json"
SHARING_ROWS = (("cuda", 1), ("cuda", 4), ("cuda", 8), ("cpu", 16))  # (device, at once)
CURVES_60K, CURVES_60K_EARLIER = "grade_s_curves_60k.json", "grade_s_curves_60k_earlier.json"


class Data:
    """The data folder's files by name; ``read`` lists those the page used, in the order first used."""

    def __init__(self, folder: Path):
        self.folder, self.read = folder, []

    def path(self, name: str) -> Path:
        if name not in self.read:
            self.read.append(name)
        return self.folder / name

    def __call__(self, name: str):
        text = self.path(name).read_text()
        if name.endswith(".jsonl"):
            return [json.loads(ln) for ln in text.splitlines() if ln.startswith("{")]
        return json.loads(text)

    def runs(self, *names: str) -> list[dict]:
        """The runs of grade_device / base_drape files, in order, those that failed left out."""
        return [r for n in names for r in self(n)["runs"] if "error" not in r]


def size(triangles: int) -> str:
    """A mesh's size as the page names it: 10K, 30K, 150K (two significant digits)."""
    return f"{float(f'{triangles / 1000:.2g}'):g}K"


def listing(items: list[str]) -> str:
    """a, b, c and d"""
    return ", ".join(items[:-1]) + f" and {items[-1]}" if len(items) > 1 else "".join(items)


def seconds(x: float) -> str:
    """0.032, 0.110, 1.17: three decimals below a second, three digits above."""
    return f"{x:.3f}" if x < 1 else f"{x:.3g}"


def grading(data: Data) -> dict[str, str]:
    """The grading loop on each device; the 60K search loop, by build and against size."""
    out = {}
    runs = sorted(data.runs(LOOP), key=lambda r: (r["triangles"], r["device"] != "cpu"))

    def done(r):
        return f"{r['outer_iterations_done']}" + (" (time budget)" if r["message"].startswith("time budget") else "")
    out["loop_table"] = table(
        [""] + [f"{'CPU' if r['device'] == 'cpu' else 'GPU'}, {size(r['triangles'])}" for r in runs],
        [["outer iterations done"] + [done(r) for r in runs],
         ["loop"] + [f"{r['seconds_loop']:.1f} s" for r in runs],
         ["simulation"] + [f"{r['split']['simulation']:.1f} s" for r in runs],
         ["adjoint (factorizations + solves, or MINRES)"] + [f"{adjoint_s(r['split']):.1f} s" for r in runs],
         ["objective reduction"] + [f"{100 * r['objective_reduction']:.1f} %" for r in runs]],
        "l" + "r" * len(runs))
    for r in runs:
        out[f"loop_{r['device']}_{size(r['triangles']).lower()}_reduction"] = f"{100 * r['objective_reduction']:.0f}"
    for name, path in DIRECT_60K.items():
        (r,) = data.runs(path)
        out[f"direct_{name}_loop"] = f"{r['seconds_loop']:.1f} s"
        out[f"direct_{name}_reduction"] = f"{100 * r['objective_reduction']:.1f} %"
    (r,) = data.runs(DIRECT_60K["gpu_state"])  # the 60K mesh of the gradings the page quotes
    out.update(fine_triangles=f"{r['triangles']:,}", fine_vertices=f"{r['vertices']:,}")
    (r,) = data.runs(BODICE_60K)
    out.update(bodice_triangles=f"{r['triangles']:,}", bodice_loop=f"{r['seconds_loop']:.1f} s",
               bodice_reduction=f"{100 * r['objective_reduction']:.1f} %")
    for r in data.runs(*BY_SIZE):
        out[f"per_outer_{size(r['triangles']).lower()}"] = seconds(r["seconds_per_iteration"])
    return out


def pieces(data: Data) -> dict[str, str]:
    """The simulator's iteration, the adjoint solve, the base drape."""
    sim = merge([data.path(n) for n in SIMULATOR])
    cpu = fastest(sim["cpu"])
    rows = []
    for g in sim["gpu"]:
        c = cpu[g["size"]]["cpu_us_per_iteration"]
        rows.append([f"{g['triangles']:,}", f"{g['gpu_us_per_iteration_graph']:.1f}", f"{c:,.0f}",
                     f"{c / g['gpu_us_per_iteration_graph']:.0f}x"])
    threads = _threads(next(iter(cpu.values()))["cpu_threads"])
    out = {"iteration_table": table(["triangles", "GPU us/iteration", f"CPU us/iteration ({threads})", "GPU speed-up"],
                                    rows, "rrrr")}
    runs = {}
    for r in sim["cpu"]:  # each size's CPU runs, in the order measured
        runs.setdefault(r["size"], []).append(f"{r['cpu_us_per_iteration']:,.0f}")
    out["cpu_runs"] = ", ".join(f"{' / '.join(v)}{' us' if i == 0 else ''} at {k.upper()}"
                                for i, (k, v) in enumerate(runs.items()))
    ns = [r["ns_per_triangle_iteration"] for r in data(CHEBYSHEV)["convergence"]
          if r["method"] == "chebyshev" and r["threads"] == 1]
    out["chebyshev_ns"] = f"{min(ns):.0f}-{max(ns):.0f}"

    adj = data(ADJOINT)
    out["adjoint_table"] = table(
        ["triangles", "CPU LDL^T factorize + solve", f"GPU MINRES setup + solve ({adj['meta']['path']})",
         "us per MINRES iteration"],
        [[f"{r['triangles']:,}", f"{r['cpu']['factorize_s']:.3f} + {r['cpu']['solve_s']:.3f} s",
          f"{g['setup_s']:.3f} + {g['solve_s']:.3f} s", f"{g['us_per_iteration']:.1f}"]
         for r in adj["rows"] for g in r["gpu"]], "rrrr")
    out["adjoint_other_run"] = listing([f"{r['cpu']['factorize_s']:.3f}" for n in ADJOINT_GRAPH
                                        for r in data(n)["rows"]])
    minres = {size(z["triangles"]): z for z in data(MINRES_SIZES)}
    z = minres["60K"]
    out.update(minres_60k_triangles=f"{z['triangles']:,}", minres_60k_persistent=f"{z['us_per_iteration_persistent']:.1f}",
               minres_60k_graph=f"{z['us_per_iteration_graph']:.1f}")
    # the persistent kernel against the graph of 4 kernels, at the sizes of the loop's table
    loop = {size(r["triangles"]) for r in data.runs(LOOP)}
    gain = [1 - z["us_per_iteration_persistent"] / z["us_per_iteration_graph"] for k, z in minres.items() if k in loop]
    out["persistent_gain"] = f"{100 * statistics.mean(gain):.0f} %"

    for r in data.runs(*DRAPES):
        k = f"{r['device']}_{size(r['triangles']).lower()}"
        out[f"drape_triangles_{size(r['triangles']).lower()}"] = f"{r['triangles']:,}"
        out[f"drape_{k}"] = f"{r['seconds']:.1f} s"
        polish = [s["seconds"] for s in r["stages"] if s["stage"] == "polish"]
        if polish:
            out[f"drape_{k}_polish"] = f"{sum(polish):.0f} s"
    return out


def throughput(data: Data) -> dict[str, str]:
    """Run time against error; many gradings on one host and on one GPU."""
    out = {}
    for name, path in ACCURACY_TIME.items():
        cases = [c for c in data(path)["cases"] if "error" not in c]
        got = reached(cases, BUDGET_S)
        out[f"at{BUDGET_S}_{name}"] = f"{statistics.median(g['landmark_max_cm'] for g in got):.2f}"
        out[f"at{BUDGET_S}_{name}_reached"] = f"{len(got)} of {len(cases)}"

    runs = [data(n) for n in BATCH]
    cpu = max(runs, key=lambda run: run.get("rounds", 2))  # the most jobs per worker: the steady state
    rows = sorted((r for r in cpu["rows"] if r["kind"] == "cpu"), key=lambda r: r["workers"])
    gpu = sorted((r for run in runs for r in run["rows"] if r["kind"] == "gpu"), key=lambda r: r["gpus"])
    out.update(batch_one_core=f"{rows[0]['per_hour']:,.0f}", batch_all_cores=f"{rows[-1]['per_hour']:,.0f}",
               batch_linear=f"{vs_linear(cpu, rows[-1]):.2f}x", batch_one_gpu=f"{gpu[0]['per_hour']:,.0f}",
               batch_two_gpus=f"{gpu[-1]['per_hour']:,.0f}",
               batch_gpu_gain=f"{gpu[-1]['per_hour'] / gpu[0]['per_hour']:.2f}x")

    run = data(SHARING)
    by = {(r["device"], r["at_once"]): r for r in run["rows"]}
    out["sharing_table"] = table(
        ["on", "at once", "gradings an hour", "against one at once", "median grading"],
        [["GPU" if d == "cuda" else f"{run['machine']['cores']} CPU cores", str(k), f"{by[d, k]['per_hour']:,.0f}",
          f"{vs_one(run, by[d, k]):.2f}x", f"{by[d, k]['grading_s_median']:.1f} s"] for d, k in SHARING_ROWS],
        "lrrrr")
    out["sharing_busy"] = f"{by['cuda', 1]['gpu_util_mean_pct']:.0f} %"
    return out


def curves(data: Data, docs: Path) -> dict[str, str]:
    """The paper's Fig. 10 at 60K: the defaults' table and picture, and the earlier run's ends."""
    now, before = data(CURVES_60K), data(CURVES_60K_EARLIER)
    plot_curves(now["runs"], docs, "grade_s_curves_60k.png")
    runs = before["runs"]
    return {"curves_60k_run": "; ".join(f"`{m['command']}` ({m['machine']}, {m['gpu']})" for m in now["metas"]),
            "curves_60k_table": curves_table(now["runs"], ".1f"),
            "curves_earlier_loop": listing([f"{r['seconds_loop']:.0f}" for r in runs]),
            "curves_earlier_S": listing([str(r["S"]) for r in runs]),
            "curves_earlier_final": listing([f"{r['objective_final']:.2f}" for r in runs])}


def cmd_report(a) -> int:
    data = Data(a.results)
    values = {**grading(data), **pieces(data), **throughput(data), **curves(data, a.docs)}
    values["data_files"] = ", ".join(f"`{n}`" for n in data.read)
    atomic_write_text(a.docs / "speed.md", fill(a.notes.read_text(), values))
    print(f"wrote {a.docs / 'speed.md'} and {a.docs / 'img' / 'grade_s_curves_60k.png'}")
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    q = cli.add_report(cmd_report, nargs=None)
    q.add_argument("--notes", type=Path, default=NOTES,
                   help="the page's text, with a <!-- name --> for each value (default tests/benchmarks/speed_notes.md)")
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
