"""Benchmark: SDF build time of a 27K-triangle body at 5 mm and 2.5 mm, and accuracy.

    PYTHONPATH=native/python python tests/benchmarks/bench_sdf.py [BODY.obj] [--threads N] [--repeat R]

Uses /work/shared/data/bodies/women_size06.obj when present, else the sample body.
Prints per-phase times (best of --repeat builds, no cache), the thread count and the
machine's core count, and the node / interpolation errors against exact brute-force
distances at random points. Timings on a shared machine are noisy: compare the
reported load average.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))
sys.path.insert(0, str(ROOT / "tests"))

from seamfit.body import build_sdf, load_body  # noqa: E402
from test_sdf import brute_distance, brute_winding, interp_bound  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    shared = Path("/work/shared/data/bodies/women_size06.obj")
    ap.add_argument("body", nargs="?", default=str(shared if shared.exists() else
                                                   ROOT / "sample_files" / "bodies" / "women_size06.obj"))
    ap.add_argument("--threads", type=int, default=0, help="OpenMP threads (0: default)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--spacings", type=float, nargs="+", default=[0.005, 0.0025])
    ap.add_argument("--points", type=int, default=300, help="random points for the accuracy check")
    args = ap.parse_args()

    body = load_body(args.body)
    print(f"body {args.body}: {body.n_vertices} vertices, {body.n_faces} triangles")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    rng = np.random.default_rng(0)
    results = []
    for h in args.spacings:
        best = None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            sdf = build_sdf(body, spacing=h, cache=False, threads=args.threads)
            wall = time.perf_counter() - t0
            if best is None or wall < best[0]:
                best = (wall, sdf.info)
        wall, info = best
        nx, ny, nz = sdf.dims
        idx = np.stack([rng.integers(0, n, args.points) for n in (nx, ny, nz)], axis=1)
        P = sdf.origin + h * idx
        got = sdf.values[idx[:, 2], idx[:, 1], idx[:, 0]].astype(np.float64)
        exact = brute_distance(P, body.vertices, body.faces)
        node_err = np.abs(got) - exact
        Q = sdf.origin + h * (idx + rng.random(idx.shape) * 0.999)
        Q[: args.points // 2] = _near_surface(body, args.points // 2, rng)
        phi, _ = sdf.sample(Q)
        dq = brute_distance(Q, body.vertices, body.faces)
        signed = np.where(brute_winding(Q, body.vertices, body.faces) > 0.5, -dq, dq)
        err = np.abs(phi - signed)
        row = {
            "spacing_m": h, "dims": [nx, ny, nz], "nodes": int(sdf.values.size), "threads": info["threads"],
            "wall_s": round(wall, 3), "core_s": round(info["seconds_total"], 3),
            "band_s": round(info["seconds_band"], 3), "propagate_s": round(info["seconds_propagate"], 3),
            "sign_s": round(info["seconds_sign"], 3),
            "node_err_max_m": float(node_err.max()), "node_err_median_m": float(np.median(np.abs(node_err))),
            "sample_err_max_m": float(err.max()), "sample_err_median_m": float(np.median(err)),
            "sample_err_over_bound_max": float((err / (interp_bound(sdf, Q) + 1e-12)).max()),
            "load_average": round(os.getloadavg()[0], 2),
        }
        results.append(row)
        print(f"h = {h * 1000:g} mm: {nx} x {ny} x {nz} = {row['nodes'] / 1e6:.1f} M nodes, "
              f"{row['threads']} threads: {wall:.2f} s (band {row['band_s']:.2f}, propagate "
              f"{row['propagate_s']:.2f}, sign {row['sign_s']:.2f}); node error max "
              f"{row['node_err_max_m'] * 1e3:.3f} mm, median {row['node_err_median_m'] * 1e3:.2g} mm; "
              f"sampled error max {row['sample_err_max_m'] * 1e3:.3f} mm (bound {np.sqrt(3) / 2 * h * 1e3:.2f} mm), "
              f"median {row['sample_err_median_m'] * 1e3:.3f} mm")
        del sdf
    print(json.dumps(results))
    return 0


def _near_surface(body, n, rng):
    f = rng.integers(0, body.n_faces, n)
    w = rng.dirichlet([1, 1, 1], n)
    S = (body.vertices[body.faces[f]] * w[:, :, None]).sum(axis=1)
    return S + rng.normal(scale=0.01, size=S.shape)


if __name__ == "__main__":
    raise SystemExit(main())
