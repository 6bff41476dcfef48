"""A size run in one command against one `seamfit grade` call per size: wall seconds of
each, on the same settings, and each size's objective, iterations and its largest outline
difference between the two ways (cm). Prints numbers; not a test.

    PYTHONPATH=native/python .venv/bin/python tests/benchmarks/bench_grade_run.py \
        [--data ../shared/data] [--sizes 10 14 16] [--edge-length 4] [--max-iterations 64]

The disk cache is warm for both (a first `seamfit grade` call fills it with the base body's
field and the base drape), so what is compared is what a run shares beyond the disk cache
(one process, the base's mesh, field, drape and ease in memory) and its warm starts.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--pattern", default="gc_pencil_skirt")
    ap.add_argument("--base", default="06")
    ap.add_argument("--sizes", nargs="+", default=["10", "14", "16"])
    ap.add_argument("--edge-length", default="4")
    ap.add_argument("--sdf-spacing", default="0.005")
    ap.add_argument("--max-iterations", default="64")
    args = ap.parse_args()
    pattern = args.data / "patterns" / args.pattern / f"size{args.base}" / "pattern.json"
    body = lambda s: str(args.data / "bodies" / f"women_size{s}.obj")   # noqa: E731
    common = ["--edge-length", args.edge_length, "--sdf-spacing", args.sdf_spacing, "--max-iterations",
              args.max_iterations, "--checkpoint-every", "16", "--no-picture", "-q", "--force"]
    cmd = [sys.executable, "-m", "seamfit"]
    from seamfit.pattern import load_pattern
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # fill the disk cache (base field, base drape) so neither side pays for it
        subprocess.run([*cmd, "grade", str(pattern), "--base-body", body(args.base), "--target-body",
                        body(args.sizes[0]), "--out", str(tmp / "warmup"), *common, "--max-iterations", "0"],
                       check=True)
        t = time.perf_counter()
        for s in args.sizes:
            subprocess.run([*cmd, "grade", str(pattern), "--base-body", body(args.base), "--target-body", body(s),
                            "--out", str(tmp / f"one_{s}"), *common], check=True)
        separate = time.perf_counter() - t
        t = time.perf_counter()
        subprocess.run([*cmd, "grade-run", str(pattern), "--base-body", body(args.base), "--target-bodies",
                        *map(body, args.sizes), "--out", str(tmp / "run"), *common], check=True)
        together = time.perf_counter() - t
        print(f"{len(args.sizes)} sizes of {args.pattern} (edge {args.edge_length} cm, field {args.sdf_spacing} m, "
              f"<= {args.max_iterations} iterations)")
        print(f"  {len(args.sizes)} separate `seamfit grade` calls: {separate:7.1f} s")
        print(f"  one `seamfit grade-run`:           {together:7.1f} s  ({together / separate:.2f} of the calls)")
        print("  size  warm from   iterations (calls / run)   objective (calls / run)   max outline diff cm")
        for s in args.sizes:
            one = json.loads((tmp / f"one_{s}" / "report.json").read_text())
            run = json.loads((tmp / "run" / f"women_size{s}" / "report.json").read_text())
            a = load_pattern(tmp / f"one_{s}" / "pattern.json")
            b = load_pattern(tmp / "run" / f"women_size{s}" / "pattern.json")
            diff = max(float(np.abs(p.outline_cm - q.outline_cm).max()) for p, q in zip(a.panels, b.panels))
            print(f"  {s:>4}  {run['size_run']['warm_start_from'] or '-':>10}   {one['outer_iterations']:>5} / "
                  f"{run['outer_iterations']:<5}              {one['objective_final']:.4f} / {run['objective_final']:.4f}"
                  f"         {diff:.3f}")


if __name__ == "__main__":
    main()
