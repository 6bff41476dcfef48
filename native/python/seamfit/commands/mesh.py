"""``seamfit mesh PATTERN --out DIR``: triangulate a pattern into a sewn-ready mesh.

Writes DIR/mesh.obj (panels at their 3D placement, metres; vt = pattern cm; one group per
panel), DIR/pattern.svg (the flat pattern at true scale) and DIR/report.json (sizes, quality,
time). The set is written into a temporary folder beside DIR and moved into place whole.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..output_set import OutputSet, add_force_argument
from .parsing import add_command, warner

EPILOG = """\
PATTERN is a sewpat-1 pattern or a GarmentCode *_specification.json (detected from content).
The two sides of every stitch get the same number of boundary vertices, paired one to one;
the panel interiors are meshed with gmsh (Frontal-Delaunay) at about --edge-length.
See docs/meshing.md.
"""


def register(subparsers) -> None:
    from .. import settings
    p = add_command(subparsers, "mesh", EPILOG)
    p.add_argument("pattern", metavar="PATTERN", type=Path, help="pattern file (.json)")
    p.add_argument("--out", metavar="DIR", type=Path, required=True,
                   help="output folder (created if missing): mesh.obj, pattern.svg, report.json")
    settings.add_options(p, "mesh")
    add_force_argument(p)
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..mesh import build_sewn_mesh, write_obj
    from ..pattern import write_svg
    from ..fileio import atomic_write_text
    from .checks import checked_pattern, number

    h = number("--edge-length", args.edge_length)
    out = Path(args.out)
    t0 = time.perf_counter()
    # the checks of seamfit validate and the size limits, before any meshing
    pattern = checked_pattern(args.pattern, h, warn=warner("mesh", args.quiet), drape=False)
    t_load = time.perf_counter() - t0
    with OutputSet(out, inputs=[args.pattern], force=args.force) as tmp:
        mesh = build_sewn_mesh(pattern, h)
        obj = write_obj(tmp / "mesh.obj", mesh)
        svg = write_svg(tmp / "pattern.svg", pattern)
        stats = mesh.stats()
        report = {
            "pattern": str(args.pattern),
            "garment_id": pattern.garment_id,
            "body_id": pattern.body_id,
            "edge_length_cm": h,
            "panels": stats["panels"],
            "vertices": stats["vertices"],
            "boundary_vertices": stats["boundary_vertices"],
            "triangles": stats["triangles"],
            "stitches": stats["stitches"],
            "sewing_pairs": stats["sewing_pairs"],
            "max_seam_count_mismatch": stats["max_seam_count_mismatch"],
            "min_angle_deg": stats["min_angle_deg"],
            "min_angle_interior_deg": stats["min_angle_interior_deg"],
            "sharp_corners": stats["sharp_corners"],
            "area_error": stats["area_error"],
            "max_area_error": stats["max_area_error"],
            "per_panel": [
                {"name": name, "vertices": int((mesh.vertex_panel == k).sum()),
                 "boundary_vertices": int(len(mesh.boundary_loops[k])),
                 "triangles": int((mesh.triangle_panel == k).sum())}
                for k, name in enumerate(mesh.panel_names)],
            "cache_key": mesh.cache_key(),
            "seconds": {"load": t_load, "mesh": stats["seconds"], "total": time.perf_counter() - t0},
            "files": {"obj": obj.name, "svg": svg.name},
        }
        atomic_write_text(tmp / "report.json", json.dumps(report, indent=1) + "\n")
    if not args.quiet:
        print(f"{args.pattern}: {stats['panels']} panels, {stats['vertices']} vertices, "
              f"{stats['triangles']} triangles, {stats['stitches']} stitches, "
              f"{stats['sewing_pairs']} sewing pairs; min angle {stats['min_angle_deg']:.1f} deg, "
              f"max area error {100 * stats['max_area_error']:.3f} %", file=sys.stdout)
        print(f"wrote {out / 'mesh.obj'}, {out / 'pattern.svg'}, {out / 'report.json'}")
    return 0
