"""Mesh every shared pattern (all garments, all bodies) and tabulate size, quality and time.

    PYTHONPATH=native/python python tests/benchmarks/bench_mesh.py run --out OUT.json [--data DIR]
        [--edge-length CM] [--fine-garment ID] [--fine-triangles N] [--compare-algorithms]
    PYTHONPATH=native/python python tests/benchmarks/bench_mesh.py report OUT.json

``run`` writes the numbers to OUT.json and docs/meshing_results.md from them (atomically),
and prints the table; it exits 1 if any pattern fails to mesh or any stitch has unmatched
vertex counts. ``report`` rewrites the page from OUT.json. --docs names another folder for
the page.
"""
from __future__ import annotations

import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "native" / "python"))

from seamfit.fileio import atomic_write_text  # noqa: E402
from seamfit.mesh import build_sewn_mesh  # noqa: E402
from seamfit.mesh.triangulate import ALGORITHMS, DEFAULT_ALGORITHM  # noqa: E402
from seamfit.pattern import load_pattern  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cli import Commands  # noqa: E402

COLUMNS = ("garment", "body", "h cm", "panels", "vertices", "triangles", "stitches", "pairs",
           "min angle", "min angle interior", "seam mismatch", "max area err %", "seconds")


def mesh_one(path: Path, h: float, algorithm: str = DEFAULT_ALGORITHM) -> dict:
    pattern = load_pattern(path)
    t0 = time.perf_counter()
    mesh = build_sewn_mesh(pattern, h, algorithm=algorithm)
    seconds = time.perf_counter() - t0
    st = mesh.stats()
    return {"garment": path.parents[1].name, "body": path.parent.name, "h cm": h,
            "panels": st["panels"], "vertices": st["vertices"], "triangles": st["triangles"],
            "stitches": st["stitches"], "pairs": st["sewing_pairs"],
            "min angle": st["min_angle_deg"], "min angle interior": st["min_angle_interior_deg"],
            "seam mismatch": st["max_seam_count_mismatch"],
            "max area err %": 100 * st["max_area_error"], "seconds": seconds}


def fmt(row: dict) -> list[str]:
    out = []
    for c in COLUMNS:
        v = row[c]
        if c in ("min angle", "min angle interior"):
            out.append(f"{v:.1f}")
        elif c == "max area err %":
            out.append(f"{v:.3f}")
        elif c == "seconds":
            out.append(f"{v:.2f}")
        elif c == "h cm":
            out.append(f"{v:g}")
        else:
            out.append(str(v))
    return out


def table(rows: list[dict]) -> str:
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(fmt(r)) + " |" for r in rows]
    return "\n".join(lines)


def summary(rows: list[dict]) -> str:
    v = np.array([r["vertices"] for r in rows])
    t = np.array([r["triangles"] for r in rows])
    s = np.array([r["seconds"] for r in rows])
    return (f"{len(rows)} patterns; vertices {v.min()}..{v.max()} (median {int(np.median(v))}), "
            f"triangles {t.min()}..{t.max()} (median {int(np.median(t))}); "
            f"min angle {min(r['min angle'] for r in rows):.1f} deg overall, "
            f"{min(r['min angle interior'] for r in rows):.1f} deg away from sharp corners; "
            f"max seam count mismatch {max(r['seam mismatch'] for r in rows)}; "
            f"max area error {max(r['max area err %'] for r in rows):.3f} %; "
            f"seconds per pattern median {np.median(s):.2f}, max {s.max():.2f}, total {s.sum():.1f}")


def cmd_run(args) -> int:
    files = sorted(args.data.glob("*/*/pattern.json"))
    if not files:
        print(f"no patterns under {args.data}", file=sys.stderr)
        return 1
    failures = []
    rows = []
    for f in files:
        try:
            row = mesh_one(f, args.edge_length)
        except Exception as exc:  # keep going: the table says what failed
            failures.append(f"{f}: {type(exc).__name__}: {exc}")
            print(failures[-1], file=sys.stderr)
            continue
        rows.append(row)
        print(" | ".join(fmt(row)), flush=True)
        if row["seam mismatch"] != 0:
            failures.append(f"{f}: seam vertex counts differ by {row['seam mismatch']}")

    fine_rows = []
    fine_file = args.data / args.fine_garment / "size06" / "pattern.json"
    if fine_file.exists():
        base = next((r for r in rows if r["garment"] == args.fine_garment and r["body"] == "size06"), None)
        if base is not None:
            # triangles scale as 1 / h^2
            h_fine = round(args.edge_length * math.sqrt(base["triangles"] / args.fine_triangles), 2)
            fine_rows.append(mesh_one(fine_file, h_fine))
            print(" | ".join(fmt(fine_rows[-1])), flush=True)

    algorithms = []
    if args.compare_algorithms:
        for algo in ALGORITHMS:
            res = [mesh_one(f, args.edge_length, algo) for f in files]
            # the comparison keeps its totals, not every pattern's mesh again
            algorithms.append({"algorithm": algo, "triangles": sum(r["triangles"] for r in res),
                               "min angle": min(r["min angle"] for r in res),
                               "median min angle": float(np.median([r["min angle"] for r in res])),
                               "seconds": sum(r["seconds"] for r in res)})
            print(algo, summary(res), flush=True)

    meta = {"command": " ".join(sys.argv), "data": str(args.data), "edge_length_cm": args.edge_length,
            "algorithm": DEFAULT_ALGORITHM, "python": f"{platform.python_implementation()} {platform.python_version()}",
            "machine": platform.machine(), "fine_garment": args.fine_garment, "fine_triangles": args.fine_triangles}
    data = {"meta": meta, "rows": rows, "fine": fine_rows, "algorithms": algorithms, "failures": failures}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(data, indent=1) + "\n")
    print(summary(rows))
    write_page(args.docs / "meshing_results.md", data)
    return 1 if failures else 0


def write_page(path: Path, d: dict) -> None:
    m, rows = d["meta"], d["rows"]
    text = [
        "# Meshing results",
        "",
        f"Every pattern under `{m['data']}` meshed by `seamfit.mesh.build_sewn_mesh` at "
        f"{m['edge_length_cm']:g} cm with gmsh {m['algorithm']} "
        f"(`tests/benchmarks/bench_mesh.py`; {m['python']}, {m['machine']}, times on a shared 2-core machine, "
        "so they are indicative). Angles in degrees; \"interior\" excludes triangles touching an "
        "outline corner sharper than 50 deg (none in these patterns: dart tips point into the panel). "
        "Area error: |mesh area - outline area| / outline area, worst panel. Seam mismatch: the "
        "largest difference, over all stitches, between the vertex counts of the two sides.",
        "",
        "## Summary",
        "",
        summary(rows) if rows else "no pattern meshed",
        "",
    ]
    if d["failures"]:
        text += ["## Failures", ""] + [f"- {x}" for x in d["failures"]] + [""]
    if d["fine"]:
        text += ["## Fine mesh", "", f"{m['fine_garment']}/size06 at about {m['fine_triangles']} triangles:", "",
                 table(d["fine"]), ""]
    if d["algorithms"]:
        text += ["## gmsh 2D algorithms", "",
                 f"All patterns at {m['edge_length_cm']:g} cm with each algorithm (Laplacian smoothing as "
                 "configured in `seamfit.mesh.triangulate`):", "",
                 "| algorithm | triangles | min angle | median per-pattern min angle | seconds |",
                 "|---|---|---|---|---|"]
        text += [f"| {a['algorithm']} | {a['triangles']} | {a['min angle']:.1f} | {a['median min angle']:.1f} | "
                 f"{a['seconds']:.1f} |" for a in d["algorithms"]]
        text.append("")
    text += ["## All patterns", "", table(rows), ""]
    atomic_write_text(path, "\n".join(text))
    print(f"wrote {path}")


def cmd_report(args) -> int:
    write_page(args.docs / "meshing_results.md", json.loads(args.results.read_text()))
    return 0


def main(argv=None) -> int:
    cli = Commands(__doc__)
    ap = cli.add_run(cmd_run)
    ap.add_argument("--docs", type=Path, default=ROOT / "docs", help="where the page goes")
    ap.add_argument("--data", type=Path, default=Path("/work/shared/data/patterns"))
    ap.add_argument("--edge-length", type=float, default=1.5)
    ap.add_argument("--fine-garment", default="gc_pants",
                    help="garment (its size06) also meshed finely")
    ap.add_argument("--fine-triangles", type=int, default=60000,
                    help="about this many triangles for the fine mesh")
    ap.add_argument("--compare-algorithms", action="store_true",
                    help="also mesh everything with every gmsh algorithm and summarise")
    cli.add_report(cmd_report, nargs=None)
    return cli.main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
