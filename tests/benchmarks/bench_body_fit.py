"""Bodies from measurements: accuracy and time (docs/bodies.md, "Bodies from measurements").

1. Every sample body of sample_files/bodies/measurements.json made from its requested
   measurements: achieved values, the largest error, the distance to the sample mesh (the
   body its MakeHuman parameters give) and the fitting time.
2. The women's size chart of that file (US misses 2-16) made into a size run, drawn as one
   picture (front and side), with its requested and achieved measurements.

    PYTHONPATH=native/python python tests/benchmarks/bench_body_fit.py \
        [--json docs/results/data/body_fit_results.json] [--picture docs/img/body_size_run.png]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from seamfit.body import MEASUREMENTS, from_measurements
from seamfit.body.shape_model import ShapeParameters, shape_vertices

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = json.loads((ROOT / "sample_files/bodies/measurements.json").read_text())


def sample_vertices(entry: dict) -> np.ndarray:
    p = entry["makehuman_parameters"]
    m = p["macro"]
    return shape_vertices(ShapeParameters(gender=m["gender"], weight=m["weight"], height=m["height"],
                                          cupsize=m.get("cupsize", 0.5), local=p["measurement_targets"]))


def fit(requested: dict, gender: str, name: str) -> dict:
    t0 = time.perf_counter()
    c0 = time.process_time()
    made = from_measurements({k: v for k, v in requested.items() if v is not None}, gender=gender, name=name)
    r = made.report()
    r["wall_s"] = time.perf_counter() - t0
    r["cpu_s"] = time.process_time() - c0
    return r, made


def draw_size_run(bodies: list, labels: list, path: Path) -> None:
    """Front and side views of every body, side by side, shaded by a light from the
    front-left (painter's order: far triangles first)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fig, axes = plt.subplots(2, 1, figsize=(13, 9.5))
    light = np.array([0.4, -0.7, 0.6]) / np.linalg.norm([0.4, -0.7, 0.6])
    cmap = plt.get_cmap("viridis")
    # (axis across the picture, towards the viewer, spacing): the front from -Y, the left
    # side from +X (the body faces left there)
    views = ((0, np.array([0.0, -1.0, 0.0]), 0.78), (1, np.array([1.0, 0.0, 0.0]), 0.42))
    for ax, (u, towards, spacing) in zip(axes, views):
        for k, (made, label) in enumerate(zip(bodies, labels)):
            T = made.body.vertices[made.body.faces]
            n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
            n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-30
            keep = n @ towards > 0
            T, n = T[keep], n[keep]
            order = np.argsort((T @ towards).max(axis=1))
            T, n = T[order], n[order]
            across = T[:, :, u] + spacing * k
            colour = np.array(cmap(k / max(1, len(bodies) - 1)))[:3]
            shade = (0.45 + 0.55 * np.clip(n @ light, 0, 1))[:, None]
            ax.add_collection(PolyCollection(np.stack([across, T[:, :, 2]], axis=-1),
                                             facecolors=shade * (0.35 + 0.65 * colour), edgecolors="none",
                                             antialiased=False))
            if u == 0:
                ax.text(spacing * k, -0.07, label, ha="center", fontsize=10)
        ax.set_xlim(-0.45, spacing * (len(bodies) - 1) + 0.45)
        ax.set_ylim(-0.12, 1.72)
        ax.set_aspect("equal")
        ax.axis("off")
    axes[0].set_title("US misses sizes 2-16 made from the size chart (front, then side)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def table(rows: list, keys: list) -> str:
    head = "| body | " + " | ".join(keys) + " | max error | fit s |\n|---|" + "---|" * (len(keys) + 2)
    lines = [head]
    for r in rows:
        cells = []
        for k in keys:
            want = r["requested_cm"].get(k)
            got = r["achieved_cm"][k]
            cells.append(f"{want:.1f} / {got:.2f}" if want is not None else f"- / {got:.2f}")
        lines.append(f"| {r['name']} | " + " | ".join(cells) + f" | {r['max_error_cm']:.2f} | {r['wall_s']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--picture", type=Path, default=None)
    args = ap.parse_args()
    load0 = os.getloadavg()
    rows = []
    for name, entry in SAMPLES["bodies"].items():
        r, made = fit(entry["requested_cm"], entry["gender"], name)
        d = 1000 * np.linalg.norm(made.body.vertices - sample_vertices(entry), axis=1)
        r["distance_to_sample_mm"] = {"mean": float(d.mean()), "p95": float(np.percentile(d, 95)),
                                      "max": float(d.max())}
        rows.append(r)
        print(f"{name}: max error {r['max_error_cm']:.3f} cm, {r['wall_s']:.2f} s wall, {r['cpu_s']:.2f} s cpu, "
              f"{r['fit']['steps']} steps; mesh mean {d.mean():.2f} p95 {np.percentile(d, 95):.2f} "
              f"max {d.max():.2f} mm")
    run, made_run = [], []
    for size, cm in SAMPLES["size_chart"]["cm_by_size"].items():
        r, made = fit(cm, "female", f"size {size}")
        run.append(r)
        made_run.append(made)
        print(f"size {size}: max error {r['max_error_cm']:.3f} cm, {r['wall_s']:.2f} s")
    keys = [k for k in MEASUREMENTS]
    print("\n" + table(rows, keys) + "\n\n" + table(run, keys))
    walls = [r["wall_s"] for r in rows + run]
    print(f"\nfit time: median {np.median(walls):.2f} s, max {max(walls):.2f} s; load average "
          f"{load0[0]:.1f} before, {os.getloadavg()[0]:.1f} after; {os.cpu_count()} cores")
    if args.picture:
        draw_size_run(made_run, [r["name"] for r in run], args.picture)
    if args.json:
        args.json.write_text(json.dumps({"samples": rows, "size_run": run, "load_average": [load0[0], os.getloadavg()[0]],
                                         "cores": os.cpu_count()}, indent=1) + "\n")


if __name__ == "__main__":
    main()
