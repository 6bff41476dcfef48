"""``seamfit validate FILE``: check a pattern or a body file and summarise it."""
from __future__ import annotations

import math
import sys
from pathlib import Path

from ..errors import BodyError, SeamfitError
from .parsing import add_command

BODY_SUFFIXES = (".obj", ".ply")

EPILOG = """\
patterns (.json): sewpat-1 files and GarmentCode *_specification.json files; the format
  is detected from the content. Checks: closed outlines with >= 3 points (a last point
  repeating the first is a fixable warning), no zero-length segments, no self-intersections,
  declared orientation matches the outline, edge curves well-formed and finite, no
  degenerate edges (start == end), node/corner/landmark indices inside the outline,
  placement finite and a rotation, stitch sides on existing panels with ranges in bounds,
  non-gathered stitch sides of equal length within max(--seam-tolerance, --seam-tolerance-rel
  x longer side), plausible units (cm, not mm or m), names of printable characters and
  coordinates within 1 km. See docs/formats.md.
DXF-AAMA / DXF-ASTM patterns (.dxf): read as seamfit convert reads them (docs/formats.md,
  "DXF"), with the stitches and placements of the seams sidecar beside the file
  (<name>.seams.json) or --seams; then the same checks. The reader's notes (a broken cut
  line dropped, a far piece moved) are printed as "note:" lines. A multi-size DXF (pieces
  of several sizes, each with its Size: text) is checked size by size, or one with --size;
  so is a graded base DXF with its RUL grade-rule table given by --rul.
notches across a seam: where both sides of a stitch carry notches, they must sit at the
  same arc length from the seam's start (read as the stitch joins the sides) within
  NOTCH_MATCH_CM; a notch without its partner is a warning naming the stitch and notch.
bodies (.obj, .ply): loaded and checked by seamfit.body.

exit status: 0 valid (warnings allowed unless --strict), 1 validation errors found
  (or warnings with --strict), 2 the file could not be read or is not a pattern/body.
"""


def register(subparsers) -> None:
    from ..pattern import SEAM_TOLERANCE_CM, SEAM_TOLERANCE_REL
    p = add_command(subparsers, "validate", EPILOG)
    p.add_argument("file", metavar="FILE", help="pattern .json (sewpat-1 or GarmentCode "
                   "*_specification.json), pattern .dxf (AAMA/ASTM) or body mesh .obj/.ply")
    p.add_argument("--dxf-units", choices=("mm", "cm", "in", "m"), default=None,
                   help="units of a DXF pattern, overriding its header (default: from $INSUNITS or "
                        "its Units text)")
    p.add_argument("--size", metavar="NAME", default=None,
                   help="of a multi-size DXF, check this size only (default: every size in turn)")
    p.add_argument("--rul", metavar="RULES.rul", type=Path, default=None,
                   help="a base DXF's RUL grade-rule table: check every size it grades to (or --size)")
    p.add_argument("--seams", metavar="SEAMS.json", type=Path, default=None,
                   help="a DXF pattern's seams sidecar (default: <name>.seams.json beside it, if any)")
    p.add_argument("--seam-tolerance", type=float, default=SEAM_TOLERANCE_CM, metavar="CM",
                   help="absolute length difference allowed between the two sides of a "
                        f"non-gathered stitch (default {SEAM_TOLERANCE_CM} cm)")
    p.add_argument("--seam-tolerance-rel", type=float, default=SEAM_TOLERANCE_REL, metavar="FRAC",
                   help="relative difference allowed, as a fraction of the longer side; the larger "
                        f"of the two tolerances applies (default {SEAM_TOLERANCE_REL})")
    p.add_argument("--strict", action="store_true", help="treat warnings as errors (exit 1)")
    p.add_argument("--svg", metavar="OUT.svg", type=Path,
                   help="also draw the pattern to a true-scale SVG (1 unit = 1 cm)")
    p.add_argument("--fix", metavar="OUT.json", type=Path,
                   help="repair fixable problems (a repeated closing point) and write the result "
                        "as sewpat-1 to OUT.json; the input file is never overwritten")
    p.add_argument("-q", "--quiet", action="store_true", help="print only problems, no summary")
    p.set_defaults(func=run)


def run(args) -> int:
    try:
        path = Path(args.file)
        if not path.exists():
            raise SeamfitError(f"{path}: no such file")
        if path.suffix.lower() in BODY_SUFFIXES:
            return _run_body(args)
        return _run_pattern(args)
    except SeamfitError as exc:
        # reported here too so the command behaves the same when called on its own
        for line in exc.lines():
            print(f"seamfit validate: error: {line}", file=sys.stderr)
        return 2


def _run_pattern(args) -> int:
    from ..output_set import check_not_an_input
    from ..pattern import read_pattern_file

    if not (args.seam_tolerance >= 0 and math.isfinite(args.seam_tolerance) and 0 <= args.seam_tolerance_rel < 1):
        raise SeamfitError("--seam-tolerance must be a finite number >= 0 and --seam-tolerance-rel in [0, 1)")
    for out in (args.fix, args.svg):   # neither may replace the file being checked
        if out is not None:
            check_not_an_input(out, [args.file])
    size = getattr(args, "size", None)
    dxf_units, seams = getattr(args, "dxf_units", None), getattr(args, "seams", None)
    rul = getattr(args, "rul", None)
    if Path(args.file).suffix.lower() == ".dxf" and size is None:
        from ..pattern import read_dxf_size_file
        sizes = read_dxf_size_file(args.file, dxf_units=dxf_units, seams=seams, rul=rul)
        if len(sizes.patterns) > 1:
            if args.fix is not None or args.svg is not None:
                raise SeamfitError(f"{args.file}: --fix and --svg take one size of a multi-size DXF; choose one "
                                   f"with --size NAME ({', '.join(sizes.labels)})")
            codes = [_check_one(pattern, f"dxf-{sizes.flavor}", args, label)
                     for label, pattern in sizes.patterns.items()]
            return max(codes)
        pattern, fmt = next(iter(sizes.patterns.values())), f"dxf-{sizes.flavor}"
    else:
        pattern, fmt = read_pattern_file(args.file, dxf_units=dxf_units, seams=seams, size=size, rul=rul)
    return _check_one(pattern, fmt, args, size)


def _check_one(pattern, fmt: str, args, size: str | None) -> int:
    from ..pattern import save_pattern, validate_pattern, write_svg
    from ..pattern import fix_pattern

    report = validate_pattern(pattern, seam_tolerance_cm=args.seam_tolerance,
                              seam_tolerance_rel=args.seam_tolerance_rel)
    out = sys.stdout
    if not args.quiet:
        n_vert = sum(len(p.outline_cm) for p in pattern.panels)
        ident = ", ".join(f"{k} {v}" for k, v in (("garment", pattern.garment_id), ("body", pattern.body_id)) if v)
        kind = {"garmentcode": "GarmentCode specification", "dxf-aama": "DXF-AAMA",
                "dxf-astm": "DXF-ASTM"}.get(fmt, fmt)
        print(f"{args.file}: {kind}" + (f", size {size}" if size is not None else "")
              + (f" ({ident})" if ident else ""), file=out)
        print(f"  panels: {len(pattern.panels)}, vertices: {n_vert}, stitches: {len(pattern.stitches)} "
              f"({sum(s.gathered for s in pattern.stitches)} gathered), warnings: {len(report.warnings)}, "
              f"errors: {len(report.errors)}", file=out)
        for p in pattern.panels:
            print(f"  - {p.name}: {len(p.outline_cm)} vertices, {len(p.edges)} edges, "
                  f"{len(p.corners)} corners, {abs(p.signed_area_cm2()):.1f} cm2, {p.orientation}", file=out)
    for m in (pattern.extra.get("source") or {}).get("notes", []) if fmt.startswith("dxf") else []:
        print(f"note: {m}", file=out)
    for m in report.warnings:
        print(f"warning: {m}", file=out)
    for m in report.errors:
        print(f"error: {m}", file=sys.stderr)
    if args.fix is not None:
        done = fix_pattern(pattern)
        save_pattern(pattern, args.fix)
        for m in done:
            print(f"fixed: {m}", file=out)
        print(f"wrote {args.fix}", file=out)
    if args.svg is not None:
        write_svg(args.svg, pattern, title=Path(args.file).name)
        print(f"wrote {args.svg}", file=out)
    failed = bool(report.errors) or (args.strict and bool(report.warnings))
    if not args.quiet:
        print("INVALID" if failed else "OK", file=out)
    return 1 if failed else 0


def _run_body(args) -> int:
    # bodies live in seamfit.body; imported here so patterns work without it
    try:
        from ..body import load_body, validate_body
    except ImportError as exc:
        raise SeamfitError(f"{args.file}: cannot check bodies, seamfit.body is not available ({exc})") from exc
    body = load_body(args.file)                     # unreadable: exit 2 via the caller
    try:
        report = validate_body(body)
    except BodyError as exc:                        # a body that loads but fails its checks
        report, errors = None, [str(exc)]
    else:
        errors = list(getattr(report, "errors", []) or [])
    warnings = list(getattr(report, "warnings", []) or [])
    if not args.quiet:
        print(f"{args.file}: body")
        if report is not None and not errors:
            print(_body_summary(report.stats))
    for m in warnings:
        print(f"warning: {m}")
    for m in errors:
        print(f"error: {m}", file=sys.stderr)
    failed = bool(errors) or (args.strict and bool(warnings))
    if not args.quiet:
        print("INVALID" if failed else "OK")
    return 1 if failed else 0


def _body_summary(st: dict) -> str:
    yes = {True: "yes", False: "no"}
    return (f"  vertices: {st['n_vertices']}, faces: {st['n_faces']}, height: {st['height_m']:.3f} m, "
            f"volume: {st['volume_litres']:.1f} litres, components: {st['components']}, "
            f"watertight: {yes[st['watertight']]}, inverted: {yes[st['inverted']]}")
