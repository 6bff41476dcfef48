"""The simulator on the GPU against the CPU: time per iteration against triangle
count, kernel times and memory traffic, float32 against float64, and time
against residual for a drape.

    # where gmsh is (meshes and start positions of one garment at several sizes):
    PYTHONPATH=native/python python tests/benchmarks/bench_cuda.py prepare --dir MESHES
    # on the GPU machine (writes results.json and the plots under OUT):
    PYTHONPATH=native/python python tests/benchmarks/bench_cuda.py run --dir MESHES --out OUT
    # the CPU part alone (e.g. on a development box):
    PYTHONPATH=native/python python tests/benchmarks/bench_cuda.py cpu --dir MESHES --out OUT
    # docs/gpu_results.md and its plots from results.json files (several: the CPU runs add up,
    # the table takes each size's fastest; --cpu-dev: a development box's CPU run):
    python tests/benchmarks/bench_cuda.py report OUT/results.json [--cpu-dev DEV/results.json]

The garment is GarmentCode's circle skirt (size 06) on the size 06 body,
remeshed finer for each size; the body's SDF is built where the benchmark
runs (2.5 mm, the drape command's default, over the skirt's height only).

The page's text is tests/benchmarks/gpu_results_notes.md (--notes): the report puts each
table where that file has a line <!-- iterations -->, <!-- kernels -->, <!-- ncu -->,
<!-- precision --> or <!-- drapes -->. The Nsight Compute table is the results' "ncu" rows:
per kernel, the medians of `ncu --clock-control none` over ncu-target (the fields of
bench_adjoint_gpu.ncu_table, and "instructions").
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))
from doc_page import fill, table  # noqa: E402

PATTERNS = ROOT / "sample_files" / "patterns"
GARMENT = PATTERNS / "gc_circle_skirt" / "size06" / "pattern.json"
# The drape comparison also uses the pencil skirt, which converges in fewer iterations.
PENCIL = PATTERNS / "gc_pencil_skirt" / "size06" / "pattern.json"
PENCIL_EDGES = {"pencil30k": 0.64}
BODY = ROOT / "sample_files" / "bodies" / "women_size06.obj"
# Edge lengths (cm) that give about 10K, 30K, 60K, 150K and 300K triangles.
EDGES = {"10k": 1.47, "30k": 0.85, "60k": 0.60, "150k": 0.38, "300k": 0.27}
# (mesh, compare with the CPU): time against residual for these drapes.
DRAPES = (("pencil30k", True), ("60k", False))


def log(msg: str) -> None:
    print(msg, flush=True)


# ------------------------------------------------------------------ prepare
def prepare(args) -> None:
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    from seamfit.sim.dressing import initial_positions
    out = Path(args.dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(GARMENT, name, edge) for name, edge in EDGES.items()]
    jobs += [(PENCIL, name, edge) for name, edge in PENCIL_EDGES.items()]
    for path, name, edge in jobs:
        pattern = load_pattern(path)
        t0 = time.perf_counter()
        mesh = build_sewn_mesh(pattern, edge)
        x0, _ = initial_positions(mesh, pattern, None, mode="none")  # GarmentCode placements are exact
        np.savez_compressed(out / (f"{name}.npz" if name.startswith("pencil") else f"skirt_{name}.npz"), uv_cm=mesh.uv_cm, triangles=mesh.triangles.astype(np.int32),
                            sewing_pairs=mesh.sewing_pairs.astype(np.int32), x0=x0, edge_cm=edge)
        log(f"{name}: {mesh.n_vertices} vertices, {len(mesh.triangles)} triangles, "
            f"{len(mesh.sewing_pairs)} sewing pairs, {time.perf_counter() - t0:.1f} s")


def load_mesh(d: Path, name: str):
    z = np.load(d / (f"{name}.npz" if name.startswith("pencil") else f"skirt_{name}.npz"))
    return SimpleNamespace(**{k: z[k] for k in z.files})


def body_sdf(meshes):
    """The body's SDF at 2.5 mm over the garments' height (plus 10 cm)."""
    from seamfit.body import build_sdf, load_body
    body = load_body(BODY)
    lo = np.min([m.x0.min(axis=0) for m in meshes], axis=0)
    hi = np.max([m.x0.max(axis=0) for m in meshes], axis=0)
    vlo, vhi = body.vertices.min(axis=0), body.vertices.max(axis=0)
    bounds = (vlo[0] - 0.05, vlo[1] - 0.05, max(vlo[2], lo[2] - 0.3) - 0.05,
              vhi[0] + 0.05, vhi[1] + 0.05, min(vhi[2], hi[2] + 0.1) + 0.05)
    t0 = time.perf_counter()
    sdf = build_sdf(body, spacing=0.0025, bounds=bounds, cache=False)
    log(f"body SDF {sdf.values.shape[::-1]} at 2.5 mm in {time.perf_counter() - t0:.1f} s")
    return sdf


def make_sim(mesh, sdf, threads=0, **settings):
    from seamfit.sim import Fabric, SimSettings, Simulator
    sim = Simulator(mesh, sdf, Fabric(), SimSettings(threads=threads, **settings))
    return sim


def per_iteration(solve, n1, n2):
    """Seconds per iteration from two fixed-length solves (start-up cancels)."""
    t = []
    for n in (n1, n2):
        t0 = time.perf_counter()
        solve(n)
        t.append(time.perf_counter() - t0)
    return (t[1] - t[0]) / (n2 - n1)


def cpu_timings(d: Path, sizes, sdf, threads: int, n1=20, n2=60):
    rows = []
    for name in sizes:
        mesh = load_mesh(d, name)
        sim = make_sim(mesh, sdf, threads=threads, tolerance=1e-12)
        sim.solve(mesh.x0, max_iterations=5, gravity_scale=0.0)  # warm-up
        s = per_iteration(lambda n: sim.solve(mesh.x0, max_iterations=n, gravity_scale=0.0), n1, n2)
        rows.append({"size": name, "triangles": int(len(mesh.triangles)), "vertices": int(len(mesh.uv_cm)),
                     "cpu_threads": sim.core.threads, "cpu_us_per_iteration": 1e6 * s})
        log(f"CPU {name}: {len(mesh.triangles)} triangles, {sim.core.threads} threads: {1e6 * s:.0f} us/iteration")
    return rows


def peak_bandwidth():
    """Device-to-device copy of 2 GiB through CuPy, bytes read plus written."""
    try:
        import cupy as cp
    except ImportError:
        return None
    a = cp.empty(1 << 28, dtype=cp.float64)
    b = cp.empty_like(a)
    a.fill(1.0)
    b[...] = a
    cp.cuda.Device().synchronize()
    ev0, ev1 = cp.cuda.Event(), cp.cuda.Event()
    ms = []
    for _ in range(10):
        ev0.record()
        b[...] = a
        ev1.record()
        ev1.synchronize()
        ms.append(cp.cuda.get_elapsed_time(ev0, ev1))
    del a, b
    cp.get_default_memory_pool().free_all_blocks()
    return 2 * 8 * (1 << 28) / (np.median(ms) * 1e-3)


def gpu_timings(d: Path, sizes, sdf):
    from seamfit.sim.cuda import CudaSimulator
    rows = []
    for name in sizes:
        mesh = load_mesh(d, name)
        sim = make_sim(mesh, sdf, tolerance=1e-12)
        row = {"size": name, "edge_cm": float(mesh.edge_cm), "triangles": int(len(mesh.triangles)),
               "vertices": int(len(mesh.uv_cm))}
        # A state mid-way through dressing: seams closing, barrier active.
        x_mid = CudaSimulator(sim).solve(mesh.x0, max_iterations=1500)[0]
        row["active_barrier_fraction"] = float(np.mean(sim.phi(x_mid, barrier_field=True) < sim.settings.barrier_distance))
        for label, opts in (("graph", {}), ("nograph", {"use_graph": False}), ("f32", {"float_rest": True})):
            g = CudaSimulator(sim, **opts)
            g.solve(x_mid, max_iterations=64)  # warm-up, graph capture
            s = per_iteration(lambda n: g.solve(x_mid, max_iterations=n, sync=False), 1000, 5000)
            row[f"gpu_us_per_iteration_{label}"] = 1e6 * s
            if label == "graph":
                kt = g.time_kernels(x_mid, 200)
                row.update({f"kernel_{k}": v for k, v in kt.items()})
                for k in ("eval", "step"):  # the unique-byte estimate over the time, GB/s
                    row[f"kernel_{k}_gb_s"] = kt[f"{k}_bytes"] / kt[f"{k}_us"] / 1e3
                row["device"] = g.device_name
                row["device_bytes"] = g.device_bytes
        row["lanes_auto"] = CudaSimulator(sim).lanes
        for lanes in (1, 2, 4, 8):
            g = CudaSimulator(sim, lanes=lanes)
            g.solve(x_mid, max_iterations=64)
            row[f"gpu_us_per_iteration_lanes{lanes}"] = 1e6 * per_iteration(
                lambda n: g.solve(x_mid, max_iterations=n, sync=False), 1000, 5000)
        for batch in (8, 128):
            g = CudaSimulator(sim, batch=batch)
            g.solve(x_mid, max_iterations=64)
            row[f"gpu_us_per_iteration_batch{batch}"] = 1e6 * per_iteration(
                lambda n: g.solve(x_mid, max_iterations=n, sync=False), 1000, 5000)
        # float64 GPU force against the CPU, float32 rest state against float64.
        f_cpu = sim.force(x_mid)
        f64 = CudaSimulator(sim).force(x_mid)
        f32 = CudaSimulator(sim, float_rest=True).force(x_mid)
        scale = np.abs(f_cpu).max()
        wn = sim.core.weight_norm
        row["stretch_Y"] = sim.core.params.stretch_Y
        row["f_max"] = float(scale)
        row["f64_abs_err"] = float(np.abs(f64 - f_cpu).max())
        # as the page gives it: over the larger of the largest force and the stretch modulus
        row["f64_rel_err"] = float(np.abs(f64 - f_cpu).max() / max(scale, sim.core.params.stretch_Y))
        row["f32_rel_err"] = float(np.abs(f32 - f_cpu).max() / scale)
        row["f32_residual_shift"] = float(np.linalg.norm(f32 - f_cpu) / wn)  # in units of the relative residual
        for lanes in (1, 8):
            row[f"f64_abs_err_lanes{lanes}"] = float(np.abs(CudaSimulator(sim, lanes=lanes).force(x_mid) - f_cpu).max())
        rows.append(row)
        log(f"GPU {name}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
    return rows


def drape_compare(d: Path, name: str, with_cpu: bool, sdf, threads: int, cpu_seconds: float,
                  gpu_iterations: int = 300000):
    """Full drape (sew, then settle to 1e-3) of one size on the GPU (float64
    and float32 rest state) and on the CPU (time-capped per stage), each with
    an iteration budget of `gpu_iterations` per stage."""
    from bench_sim import thin_history  # the same 200 points a simulator history keeps
    mesh = load_mesh(d, name)
    out = {"size": name, "triangles": int(len(mesh.triangles)), "vertices": int(len(mesh.uv_cm))}
    results = {}
    runs = [("gpu_f64", "cuda", {}), ("gpu_f32", "cuda", {"float_rest": True})]
    if with_cpu:
        runs.append(("cpu", "cpu", {}))
    for label, dev, opts in runs:
        kw = {"max_seconds": cpu_seconds} if dev == "cpu" else {}
        sim = make_sim(mesh, sdf, threads=threads, device=dev, max_iterations=gpu_iterations, **kw)
        if opts:
            from seamfit.sim.cuda import CudaSimulator
            sim._gpu = CudaSimulator(sim, **opts)
        t0 = time.perf_counter()
        r = sim.drape()
        wall = time.perf_counter() - t0
        results[label] = r
        verdict = "converged" if r.converged else next(
            (b for b in ("time budget", "iteration budget") if b in r.message), r.message)
        out[label] = {"seconds": r.seconds, "wall": wall, "iterations": r.iterations, "residual": r.residual,
                      "converged": r.converged, "verdict": verdict, "message": r.message,
                      "max_sewing_gap_mm": r.max_sewing_gap_mm, "min_phi_mm": r.min_phi_mm,
                      "cpu_residual_at_x": float(make_sim(mesh, sdf).residual(r.x)),
                      "history": thin_history(r.history),
                      "stages": [{k: v for k, v in s.items() if not k.startswith("history")} for s in r.stages]}
        log(f"drape {name} {label}: {r.message}; {r.iterations} iterations in {r.seconds:.2f} s")
    a, b = results["gpu_f64"].x, results["gpu_f32"].x
    out["f32_vs_f64_max_mm"] = float(1e3 * np.abs(a - b).max())
    if with_cpu and results["cpu"].converged:
        out["gpu_vs_cpu_max_mm"] = float(1e3 * np.abs(a - results["cpu"].x).max())
    return out


def run(args) -> None:
    d = Path(args.dir)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sizes = args.sizes.split(",")
    res = {"meta": {"command": " ".join(sys.argv), "host": platform.node(), "cpu_count": os.cpu_count(),
                    "python": platform.python_version()}}
    path = out / "results.json"

    def save():
        path.write_text(json.dumps(res, indent=1, default=float))

    meshes = [load_mesh(d, s) for s in sizes] + [load_mesh(d, name) for name, _ in DRAPES]
    res["sdf_shape"] = None
    sdf = body_sdf(meshes)
    res["sdf_shape"] = list(sdf.values.shape[::-1])
    if args.what in ("all", "gpu"):
        res["peak_copy_bytes_per_s"] = peak_bandwidth()
        log(f"device copy bandwidth {res['peak_copy_bytes_per_s'] and res['peak_copy_bytes_per_s'] / 1e12:.2f} TB/s")
        save()
        res["gpu"] = gpu_timings(d, sizes, sdf)
        save()
    if args.what in ("all", "cpu"):
        res["cpu"] = cpu_timings(d, sizes, sdf, args.threads)
        save()
    if args.what in ("all", "drape"):
        res["drape"] = [drape_compare(d, name, cpu and not args.no_cpu_drape, sdf, args.threads, args.cpu_seconds)
                        for name, cpu in DRAPES]
        save()
    log(f"wrote {path}")


def ncu_target(args) -> None:
    """A few plain launches of each kernel for a profiler (no graph)."""
    from seamfit.sim.cuda import CudaSimulator
    mesh = load_mesh(Path(args.dir), args.size)
    sim = make_sim(mesh, body_sdf([mesh]), tolerance=1e-12)
    g = CudaSimulator(sim, use_graph=False, batch=8)
    x = g.solve(mesh.x0, max_iterations=1500)[0]
    g.solve(x, max_iterations=40, sync=False)


# ------------------------------------------------------------------- report
NOTES = Path(__file__).resolve().parent / "gpu_results_notes.md"


def merge(paths) -> dict:
    """Results files, a later one adding to earlier ones: CPU rows add up (several runs of
    one machine), drapes merge by mesh, other keys are replaced."""
    res: dict = {}
    for path in paths:
        for k, v in json.loads(Path(path).read_text()).items():
            if k == "cpu":
                res["cpu"] = res.get("cpu", []) + v
            elif k == "drape" and "drape" in res:
                by = {d["size"]: d for d in res["drape"]}
                for d in v:
                    by.setdefault(d["size"], {}).update(d)
                res["drape"] = list(by.values())
            else:
                res[k] = v
    return res


def fastest(rows: list[dict]) -> dict:
    """Per size, the CPU row with the least time per iteration."""
    best: dict = {}
    for r in rows:
        if r["size"] not in best or r["cpu_us_per_iteration"] < best[r["size"]]["cpu_us_per_iteration"]:
            best[r["size"]] = r
    return best


def _sci(x: float) -> str:
    m, e = f"{x:.1e}".split("e")
    return f"{m}e{int(e)}"  # 1.0e-4, not 1.0e-04


def _threads(n: int) -> str:
    return f"{n} thread{'s' if n != 1 else ''}"


def plot(res: dict, cpu: dict, dev: dict, img: Path) -> None:
    """The time per iteration against triangles; the residual against time of each drape
    whose history the results keep."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    img.mkdir(parents=True, exist_ok=True)
    gpu = res["gpu"]
    tri = [r["triangles"] for r in gpu]
    gname = gpu[0].get("device", "GPU").replace("NVIDIA ", "")
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    ax.loglog(tri, [r["gpu_us_per_iteration_graph"] for r in gpu], "o-", label=f"{gname}, CUDA graphs (float64)")
    ax.loglog(tri, [r["gpu_us_per_iteration_nograph"] for r in gpu], "s--", label=f"{gname}, plain launches")
    for rows, style, where in ((cpu, "^-", f"{gname} host"), (dev, "v:", "shared 2-core dev box")):
        if rows:
            rows = sorted(rows.values(), key=lambda r: r["triangles"])
            ax.loglog([r["triangles"] for r in rows], [r["cpu_us_per_iteration"] for r in rows], style,
                      label=f"CPU, {_threads(rows[0]['cpu_threads'])} ({where})")
    ax.axhline(50, color="gray", lw=0.8, ls=":")
    ax.text(tri[0], 55, "aim: 50 us at 66K triangles", fontsize=8, color="gray")
    ax.axhline(78000, color="gray", lw=0.8, ls=":")
    ax.text(tri[0], 85000, "paper: 78 ms at 59K (GTX Titan X)", fontsize=8, color="gray")
    ax.set_xlabel("triangles")
    ax.set_ylabel("microseconds per simulator iteration")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    fig.tight_layout()
    fig.savefig(img / "gpu_iteration_time.png", dpi=120)
    plt.close(fig)
    # results transcribed from a page keep no histories
    drapes = [d for d in res.get("drape", []) if "history" in d["gpu_f64"]]
    if not drapes:
        return
    fig, axes = plt.subplots(1, len(drapes), figsize=(11, 4.2))
    for ax, dr in zip(np.atleast_1d(axes), drapes):
        for label, style in (("gpu_f64", "-"), ("gpu_f32", "--"), ("cpu", "-")):
            if label not in dr:
                continue
            h = dr[label]
            name = {"gpu_f64": "GPU float64", "gpu_f32": "GPU float32 rest state",
                    "cpu": f"CPU {_threads(next(iter(cpu.values()))['cpu_threads']) if cpu else ''}"}[label]
            ax.semilogy(np.maximum(h["history"]["seconds"], 1e-3), h["history"]["residual"], style,
                        label=f"{name}: {h['iterations']} it, {h['seconds']:.1f} s")
        ax.set_xscale("log")
        ax.axhline(1e-3, color="gray", lw=0.8, ls=":")
        ax.set_xlabel("seconds (sew stage, then settle)")
        ax.set_ylabel("relative residual |f| / |m g|")
        garment = "pencil skirt" if dr["size"].startswith("pencil") else "circle skirt"
        ax.set_title(f"{garment}, {dr['triangles']} triangles", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(img / "gpu_drape_residual.png", dpi=120)
    plt.close(fig)


def tables(res: dict, cpu: dict, dev: dict) -> dict[str, str]:
    """The page's tables, by the name of the line of the notes each replaces."""
    gpu, nan = res["gpu"], {"cpu_us_per_iteration": float("nan")}
    t, dt = (_threads(next(iter(rows.values()))["cpu_threads"]) if rows else "-" for rows in (cpu, dev))
    fused = all("gpu_us_per_iteration_fused" in r for r in gpu)  # a kernel option since removed
    head = ["triangles", "vertices", "GPU us/it", "plain launches"] + ["control fused"] * fused + [
        "lanes 1 / 2 / 4 / 8", "chosen", f"CPU us/it ({t})", f"dev box ({dt})", f"GPU speed-up over {t}"]
    rows = []
    for r in gpu:
        c = cpu.get(r["size"], nan)["cpu_us_per_iteration"]
        d = dev.get(r["size"], nan)["cpu_us_per_iteration"]
        lanes = " / ".join(f"{r[f'gpu_us_per_iteration_lanes{n}']:.1f}" for n in (1, 2, 4, 8))
        rows.append([f"{r['triangles']:,}", f"{r['vertices']:,}", f"{r['gpu_us_per_iteration_graph']:.1f}",
                     f"{r['gpu_us_per_iteration_nograph']:.1f}"]
                    + [f"{r['gpu_us_per_iteration_fused']:.1f}"] * fused
                    + [lanes, str(r["lanes_auto"]), f"{c:,.0f}", f"{d:,.0f}",
                       f"{c / r['gpu_us_per_iteration_graph']:.0f}x"])
    out = {"iterations": table(head, rows)}
    bw = res.get("peak_copy_bytes_per_s") or float("nan")
    out["kernels"] = table(
        ["triangles", "eval + control us", "step us", "slot us", "eval MB", "step MB", "eval GB/s", "% of copy rate",
         "step GB/s"],
        [[f"{r['triangles']:,}", f"{r['kernel_eval_us']:.1f}", f"{r['kernel_step_us']:.1f}",
          f"{r['kernel_slot_us']:.1f}", f"{r['kernel_eval_bytes'] / 1e6:.1f}", f"{r['kernel_step_bytes'] / 1e6:.1f}",
          f"{r['kernel_eval_gb_s']:.0f}", f"{100 * r['kernel_eval_gb_s'] * 1e9 / bw:.0f} %",
          f"{r['kernel_step_gb_s']:.0f}"] for r in gpu])

    def mb(x):  # the small ones keep a digit that counts
        return f"{x:.1f}" if x >= 1 else f"{x:.2f}"
    out["ncu"] = table(
        ["kernel", "grid", "time us", "DRAM read MB", "DRAM % of peak", "L2 bytes MB", "L2 % of peak", "warps active",
         "instructions"],
        [[k["kernel"], f"{k['grid']} x {k['block']}", f"{k['time_us']:.1f}", mb(k["dram_read_mb"]),
          f"{k['dram_pct']:.0f} %", mb(k["l2_mb"]), f"{k['l2_pct']:.0f} %", f"{k['warps_pct']:.0f} %",
          f"{k['instructions'] / 1e6:.3g} M" if k["instructions"] >= 1e6 else f"{k['instructions'] / 1e3:.3g} K"]
         for k in res.get("ncu", [])])
    out["precision"] = table(
        ["triangles", "float64: max force difference (N)", "relative to max(|f|, Y)",
         "float32 rest: relative difference", "float32: shift of the residual", "float32 us/it"],
        [[f"{r['triangles']:,}", _sci(r["f64_abs_err"]), _sci(r["f64_rel_err"]), _sci(r["f32_rel_err"]),
          f"{r['f32_residual_shift']:.2g}", f"{r['gpu_us_per_iteration_f32']:.1f}"] for r in gpu])
    rows = []
    names = {"gpu_f64": "GPU float64", "gpu_f32": "GPU float32 rest", "cpu": f"CPU, {t}"}
    for dr in res.get("drape", []):
        garment = f"{'pencil' if dr['size'].startswith('pencil') else 'circle'} skirt, {dr['triangles']:,} triangles"
        for label in (k for k in names if k in dr):
            h = dr[label]
            verdict = h["verdict"] + (" (own model)" if label == "gpu_f32" and h["converged"] else "")
            if label == "gpu_f32":  # float32 against float64 means something once both settled
                vs = f"{dr['f32_vs_f64_max_mm']:.2g} mm" if h["converged"] and dr["gpu_f64"]["converged"] \
                    else "(unconverged)"
            else:
                vs = f"{dr['gpu_vs_cpu_max_mm']:.2g} mm" if label == "cpu" and "gpu_vs_cpu_max_mm" in dr else ""
            res_x = h["cpu_residual_at_x"]  # 1.0e-3 beside the tolerance, 0.059 above it
            rows.append([garment if label == "gpu_f64" else "", names[label], verdict, f"{h['iterations']:,}",
                         f"{h['seconds']:.3g}", _sci(res_x) if res_x < 0.01 else f"{res_x:.2g}",
                         f"{h['max_sewing_gap_mm']:.2f} mm", vs])
    out["drapes"] = table(["garment", "run", "verdict", "iterations", "seconds", "residual at the result, on the CPU",
                            "seam gap", "vs float64 GPU"], rows)
    return out


def report(args) -> int:
    res = merge(args.results)
    cpu = fastest(res.get("cpu", []))
    dev = fastest(json.loads(Path(args.cpu_dev).read_text())["cpu"]) if args.cpu_dev else {}
    plot(res, cpu, dev, args.docs / "img")
    blocks = tables(res, cpu, dev)
    # each line <!-- name --> of the notes is the table of that name
    page = fill(args.notes.read_text(), blocks)
    (args.docs / "gpu_results.md").write_text(page)
    print(f"wrote {args.docs / 'gpu_results.md'} and its plots under {args.docs / 'img'}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("prepare")
    p.add_argument("--dir", required=True)
    for name, what in (("run", "all"), ("cpu", "cpu")):
        p = sub.add_parser(name)
        p.add_argument("--dir", required=True)
        p.add_argument("--out", required=True)
        p.add_argument("--sizes", default=",".join(EDGES))
        p.add_argument("--threads", type=int, default=0, help="CPU threads (0: all)")
        p.add_argument("--cpu-seconds", type=float, default=60.0, help="CPU drape time cap per stage")
        p.add_argument("--no-cpu-drape", action="store_true", help="drape on the GPU only")
        p.add_argument("--what", default=what, choices=("all", "gpu", "cpu", "drape"))
    p = sub.add_parser("ncu-target")
    p.add_argument("--dir", required=True)
    p.add_argument("--size", default="60k")
    p = sub.add_parser("report")
    p.add_argument("results", type=Path, nargs="+")
    p.add_argument("--cpu-dev", type=Path, help="a development box's results (its CPU rows)")
    p.add_argument("--notes", type=Path, default=NOTES,
                   help="the page's text with a line per table (default tests/benchmarks/gpu_results_notes.md)")
    p.add_argument("--docs", type=Path, default=ROOT / "docs", help="where the page and its pictures go")
    args = ap.parse_args(argv)
    return {"prepare": prepare, "run": run, "cpu": run, "ncu-target": ncu_target, "report": report}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
