"""Level scaling (seamfit.opt.level_scale) against proportional scaling and the unchanged
pattern, on every shared garment x body case: landmark error against the drafting
system's own pattern for the target body. No optimization: this scores the start.

    python tests/benchmarks/bench_level_scale.py --data ../shared/data [--garments a,b] [--bodies x,y]
        [--edge-length 3] [--out docs/results/data/level_scale_results.json]
        [--perturb-xbar 1e-6]

--perturb-xbar SIGMA also computes each start from the base drape x-bar moved by Gaussian noise of
SIGMA metres (two draws) and prints how far the start moved (mm) and its landmark errors: whether
the start's rules (levels held by the body, sections, openings) turn rounding into a jump.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from accuracy_case import body_file, captured, measurements_cm  # noqa: E402

from seamfit.body import load_body  # noqa: E402
from seamfit.pattern import baseline_errors, landmark_errors, load_pattern  # noqa: E402
from seamfit.pattern.scale import proportional_scale  # noqa: E402


def base_context(base, b0, edge_length_cm: float):
    """The sewn mesh, base drape and base body field of one garment (what every target of
    that garment shares): a grading context of the base body to itself."""
    from seamfit.opt.grade import GradeSettings
    from seamfit.opt.prepare import prepare
    st = GradeSettings(edge_length_cm=edge_length_cm, evaluate_base_pattern=False, device="cpu")
    return prepare(base, b0, b0, st)


def level_scaled(base, ctx, b0, b1, xbar=None):
    """The level-scaled start as a pattern (through the grading's own output path) and its
    mesh's (N, 2) points (m)."""
    from seamfit.opt.level_scale import level_scaled_pattern
    from seamfit.opt.output import adjusted_pattern
    p = level_scaled_pattern(ctx.mesh, ctx.xbar if xbar is None else xbar, b0, b1, ctx.base_sdf)
    return adjusted_pattern(base, ctx.mesh, 100.0 * p).refit.pattern, p


def perturbed_starts(base, ctx, b0, b1, truth, p0, sigma: float, rng) -> dict:
    """Two starts from x-bar moved by N(0, sigma^2) metres: how far each moved from the
    unperturbed start p0 (mm, the largest pattern vertex move) and its landmark error."""
    out = {"sigma_m": sigma, "move_mm": [], "level": []}
    for _ in range(2):
        pat, p = level_scaled(base, ctx, b0, b1, ctx.xbar + rng.normal(0.0, sigma, ctx.xbar.shape))
        out["move_mm"].append(float(1000.0 * np.abs(p - p0).max()))
        out["level"].append(landmark_errors(pat, truth).max_cm)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[3] / "shared" / "data")
    ap.add_argument("--garments", default="")
    ap.add_argument("--bodies", default="")
    ap.add_argument("--edge-length", type=float, default=3.0)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--save", type=Path, default=None, help="write each start as SAVE/<garment>/<body>/level.json")
    ap.add_argument("--perturb-xbar", type=float, default=0.0, metavar="SIGMA",
                    help="also start from x-bar moved by this much noise (m) and report the move")
    a = ap.parse_args(argv)
    index = json.loads((a.data / "patterns" / "index.json").read_text())
    garments = sorted(index["garments"]) if not a.garments else a.garments.split(",")
    rows = []
    for g in garments:
        bodies = sorted(p.name for p in (a.data / "patterns" / g).iterdir() if p.is_dir() and p.name != "size06")
        if a.bodies:
            bodies = [b for b in bodies if b in a.bodies.split(",")]
        base = load_pattern(a.data / "patterns" / g / "size06" / "pattern.json")
        p0 = body_file(a.data / "bodies", "size06")
        b0 = load_body(p0)
        m0 = measurements_cm(a.data / "bodies", p0, b0)
        ctx = base_context(base, b0, a.edge_length)
        for body in bodies:
            truth = load_pattern(a.data / "patterns" / g / body / "pattern.json")
            p1 = body_file(a.data / "bodies", body)
            b1 = load_body(p1)
            m1 = measurements_cm(a.data / "bodies", p1, b1)
            t0 = time.perf_counter()
            row = {"garment": g, "body": body,
                   "unchanged": baseline_errors(base, truth).max_cm,
                   "scaled": landmark_errors(proportional_scale(base, m0, m1)[0], truth).max_cm}
            try:
                start, p0 = level_scaled(base, ctx, b0, b1)
                if a.save:
                    from seamfit.pattern import save_pattern
                    (a.save / g / body).mkdir(parents=True, exist_ok=True)
                    save_pattern(start, a.save / g / body / "level.json", overwrite=True)
                rep = landmark_errors(start, truth)
                row["level"], row["level_mean"], row["level_worst"] = rep.max_cm, rep.mean_cm, list(rep.worst)
                # signed size bias: result minus truth, per panel (does the start under-grow?)
                row["level_area_pct"] = {n: q.area_diff_pct for n, q in rep.panels.items()}
                row.update({f"level_{k}": v for k, v in captured(start, base, truth).items()})
            except Exception as exc:  # noqa: BLE001 - a benchmark records, never stops
                row["level"], row["error"] = None, f"{type(exc).__name__}: {exc}"
            row["seconds"] = time.perf_counter() - t0
            rows.append(row)
            print(f"{g:18s} {body:10s} unchanged {row['unchanged']:5.2f}  scaled {row['scaled']:5.2f}  "
                  f"level {row['level'] if row['level'] is None else round(row['level'], 2)}  "
                  f"({row['seconds']:.1f} s) {row.get('level_worst', '')} {row.get('error', '')}", flush=True)
            if a.perturb_xbar > 0 and row["level"] is not None:
                q = row["perturbed"] = perturbed_starts(base, ctx, b0, b1, truth, p0, a.perturb_xbar,
                                                        np.random.default_rng(0))
                print(f"    x-bar moved by N(0, {q['sigma_m']:g} m): start moved {max(q['move_mm']):.4f} mm, "
                      f"level {', '.join(f'{e:.3f}' for e in q['level'])}", flush=True)
    ok = [r for r in rows if r["level"] is not None]
    if ok:
        for k in ("unchanged", "scaled", "level"):
            print(f"median {k}: {np.median([r[k] for r in ok]):.2f} cm")
        print(f"mean landmark error, level: {np.mean([r['level_mean'] for r in ok]):.3f} cm")
        print(f"level better than scaled in {sum(r['level'] < r['scaled'] for r in ok)} of {len(ok)}")
        moved = [max(r["perturbed"]["move_mm"]) for r in ok if "perturbed" in r]
        if moved:
            print(f"x-bar perturbed: the start moved at most {max(moved):.4f} mm over {len(moved)} cases")
    if a.out:
        a.out.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
