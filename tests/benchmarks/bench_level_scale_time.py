"""Time seamfit.opt.level_scale.level_scaled_pattern on one garment and body pair.

    PYTHONPATH=native/python python tests/benchmarks/bench_level_scale_time.py [--edge 3]
        [--fine 0.45] [--reps 7] [--save p.npy] [--profile prof.out]

The base drape is the CPU's at ``--edge`` cm. With ``--fine E`` the pattern is meshed again
at E cm and that drape is laid onto the finer mesh (linear in each panel's plane, plus 0.2 mm
of seeded noise so that no triangle is flat): a stand-in for a fine drape, whose CPU run
takes too long here, for timing only. ``--save`` writes the result for a byte comparison.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_level_scale import base_context  # noqa: E402

from seamfit.body import load_body  # noqa: E402
from seamfit.opt.level_scale import level_scaled_pattern  # noqa: E402
from seamfit.pattern import load_pattern  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[2] / "sample_files"


def laid_onto(mesh, xbar, fine):
    """xbar of ``mesh`` carried onto the finer mesh ``fine`` of the same pattern."""
    from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator
    x = np.zeros((len(fine.uv_cm), 3))
    cvp, fvp = np.asarray(mesh.vertex_panel), np.asarray(fine.vertex_panel)
    for k in range(len(mesh.panel_names)):
        ci, fi = np.flatnonzero(cvp == k), np.flatnonzero(fvp == k)
        uv, q = np.asarray(mesh.uv_cm)[ci], np.asarray(fine.uv_cm)[fi]
        xi = LinearNDInterpolator(uv, xbar[ci])(q)
        bad = ~np.isfinite(xi).all(axis=1)
        xi[bad] = NearestNDInterpolator(uv, xbar[ci])(q[bad])
        x[fi] = xi
    return x + 2e-4 * np.random.default_rng(0).standard_normal(x.shape)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pattern", type=Path, default=SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json")
    ap.add_argument("--base-body", type=Path, default=SAMPLES / "bodies/women_size06.obj")
    ap.add_argument("--target-body", type=Path, default=SAMPLES / "bodies/women_size10.obj")
    ap.add_argument("--edge", type=float, default=3.0)
    ap.add_argument("--fine", type=float, default=None)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--save", type=Path, default=None)
    ap.add_argument("--profile", type=Path, default=None)
    a = ap.parse_args(argv)
    base = load_pattern(a.pattern)
    b0, b1 = load_body(a.base_body), load_body(a.target_body)
    ctx = base_context(base, b0, a.edge)
    mesh, xbar = ctx.mesh, ctx.xbar
    if a.fine:
        from seamfit.mesh import build_sewn_mesh
        fine = build_sewn_mesh(base, edge_length_cm=a.fine)
        mesh, xbar = fine, laid_onto(mesh, xbar, fine)
    print(f"{len(mesh.triangles)} triangles")
    p = level_scaled_pattern(mesh, xbar, b0, b1, ctx.base_sdf)   # the bodies' measurements kept
    ts = []
    for _ in range(a.reps):
        t = time.perf_counter()
        p = level_scaled_pattern(mesh, xbar, b0, b1, ctx.base_sdf)
        ts.append(time.perf_counter() - t)
    print("seconds", " ".join(f"{t:.3f}" for t in ts), f"median {np.median(ts):.3f}")
    if a.save:
        np.save(a.save, p)
    if a.profile:
        cProfile.runctx("level_scaled_pattern(mesh, xbar, b0, b1, ctx.base_sdf)", globals(), locals(),
                        str(a.profile))
        pstats.Stats(str(a.profile)).sort_stats("tottime").print_stats(25)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
