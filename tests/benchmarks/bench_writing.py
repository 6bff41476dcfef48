"""The writing stage of ``seamfit grade`` (``commands.grade.write_graded``: pattern, nest SVG
and PNG, garment OBJ, report and drape picture) timed on its own, at a mesh size no small
machine could grade: GarmentCode's pencil skirt meshed at ``--edge-length`` (0.45 cm: 59,504
triangles, as the 60K-triangle grading in docs/grading.md), its start positions standing in
for the drape and the base pattern for the graded one; the target body's measurements are
taken first, as a grading has them already.

    PYTHONPATH=native/python python tests/benchmarks/bench_writing.py [--edge-length 0.45] [--repeat 3]

Each run's seconds in turn; the first holds importing matplotlib, as in a grading. The files
are written into a temporary folder and removed (``--keep DIR`` keeps the last set).
"""
from __future__ import annotations

import argparse
import copy
import shutil
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))
SAMPLES = ROOT / "sample_files"
PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
TRUTH = SAMPLES / "patterns/gc_pencil_skirt/size10/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edge-length", type=float, default=0.45)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--keep", type=Path, default=None)
    a = ap.parse_args(argv)

    from seamfit.body import body_measurements, load_body
    from seamfit.commands.grade import write_graded
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    from seamfit.pattern.compare import baseline_errors

    base = load_pattern(PATTERN)
    truth_pattern = load_pattern(TRUTH)
    b0, b1 = load_body(B0), load_body(B1)
    body_measurements(b0), body_measurements(b1)
    mesh = build_sewn_mesh(base, a.edge_length)
    truth = (truth_pattern, baseline_errors(base, truth_pattern).to_dict())
    args = argparse.Namespace(pattern=PATTERN, base_body=B0, target_body=B1, truth=TRUTH,
                              no_picture=False, quiet=True)
    print(f"{len(mesh.triangles)} triangles, {mesh.n_vertices} vertices", flush=True)
    work = Path(tempfile.mkdtemp(prefix="bench_writing-"))
    try:
        seconds = []
        for i in range(a.repeat):
            out = work / f"run{i}"
            out.mkdir()
            result = SimpleNamespace(pattern=copy.deepcopy(base), mesh=mesh, x=mesh.x0.copy(),
                                     uv_cm=mesh.uv_cm.copy(), report={"method": "none"})
            t = time.perf_counter()
            write_graded(args, result, None, base, b0, b1, truth, out)
            seconds.append(time.perf_counter() - t)
        print("write_graded: " + ", ".join(f"{s:.3f}" for s in seconds) + " s")
        last = work / f"run{a.repeat - 1}"
        for f in sorted(last.iterdir()):
            print(f"  {f.name:13s} {f.stat().st_size:9d} bytes")
        if a.keep is not None:
            shutil.rmtree(a.keep, ignore_errors=True)
            shutil.copytree(last, a.keep)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
