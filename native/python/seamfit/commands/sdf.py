"""``seamfit sdf BODY --out PATH``: build a body's signed distance field.

Writes the field as an .npz (see seamfit.body.sdf) and a JSON report beside it
(same name, .json): grid dims, origin, spacing, build seconds, min/max phi,
whether the body is watertight, and the validation warnings. Existing files are replaced
only with --force; both are written beside each other first, then moved into place.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import BodyError
from ..fileio import atomic_write_text
from ..output_set import OutputSet, add_force_argument
from .parsing import add_command


def register(subparsers) -> None:
    p = add_command(subparsers, "sdf")
    p.add_argument("body", metavar="BODY", help="body mesh (.obj or .ply, metres, Z up)")
    p.add_argument("--out", required=True, metavar="PATH", help="output .npz (a .json report is written beside it)")
    p.add_argument("--spacing", type=float, default=0.0025, metavar="M", help="grid spacing in metres (default 0.0025)")
    p.add_argument("--padding", type=float, default=0.05, metavar="M",
                   help="margin around the body in metres (default 0.05)")
    p.add_argument("--bounds", type=float, nargs=6, default=None,
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="build only this box (metres) instead of the body's box plus padding")
    p.add_argument("--no-cache", action="store_true", help="always build (do not read or write the SDF cache)")
    add_force_argument(p, "the .npz and its .json report when they exist")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..body import build_sdf, check_body, load_body  # the compiled core loads only when needed

    out = Path(args.out)
    if out.suffix.lower() != ".npz":
        raise BodyError(f"--out {out}: the SDF is written as .npz; give a path ending in .npz")
    if not (math.isfinite(args.spacing) and args.spacing > 0):
        raise BodyError(f"--spacing {args.spacing}: must be a positive number of metres")
    if not (math.isfinite(args.padding) and args.padding >= 0):
        raise BodyError(f"--padding {args.padding}: must be >= 0 metres")
    body = load_body(args.body)
    check_body(body)  # a body that cannot make a field fails before the output checks
    report_path = out.with_suffix(".json")
    with OutputSet(out.parent, inputs=[args.body], force=args.force,
                   files=[out.name, report_path.name]) as tmp:   # the report last
        t0 = time.perf_counter()
        sdf = build_sdf(body, spacing=args.spacing, padding=args.padding, bounds=args.bounds,
                        cache=not args.no_cache)
        seconds = time.perf_counter() - t0
        sdf.save(tmp / out.name)
        info = sdf.info
        report = {
            "body": str(args.body),
            "sdf": str(out),
            "dims": list(sdf.dims),
            "origin": sdf.origin.tolist(),
            "spacing": sdf.spacing,
            "padding": args.padding,
            "bounds": args.bounds,
            "nodes": int(sdf.values.size),
            "build_seconds": info.get("build_seconds", seconds),
            "seconds": seconds,
            "from_cache": sdf.from_cache,
            "threads": info.get("threads"),
            "min_phi": float(np.min(sdf.values)),
            "max_phi": float(np.max(sdf.values)),
            "inside_nodes": info.get("inside_nodes"),
            "watertight": info.get("watertight"),
            "boundary_edges": info.get("boundary_edges"),
            "warnings": info.get("warnings", []),
        }
        atomic_write_text(tmp / report_path.name, json.dumps(report, indent=1) + "\n")
    print(f"seamfit sdf: {out} ({' x '.join(map(str, sdf.dims))} nodes, h = {sdf.spacing * 1000:g} mm, "
          f"{report['build_seconds']:.2f} s{' from cache' if sdf.from_cache else ''})")
    for w in report["warnings"]:
        print(f"seamfit sdf: warning: {w}")
    return 0
