"""``seamfit convert IN --out OUT``: a pattern from one format to another, by extension.

Reads sewpat-1 and GarmentCode JSON (.json) and DXF-AAMA/ASTM (.dxf); writes sewpat-1
(.json), SVG (.svg) and DXF (.dxf). A DXF's stitches come from its seams sidecar; a DXF
written from a pattern with stitches gets a sidecar beside it, so that converting back
gives the same stitches and placements.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import SeamfitError
from ..output_set import OutputSet, add_force_argument, check_not_an_input
from ..pattern_files import output_kind, write_pattern_files
from .parsing import add_command


EPILOG = """\
formats, by the extension of IN and OUT:
  .json   read: sewpat-1 or GarmentCode *_specification.json (detected from content);
          write: sewpat-1
  .dxf    read and write: DXF-AAMA or DXF-ASTM (ASTM D6673). Written: AAMA, or ASTM when
          OUT ends in .astm.dxf or with --dxf-flavor astm (also for .aama.dxf names).
  .svg    write: a true-scale drawing (1 unit = 1 cm)

multi-size DXF (pieces of several sizes, each with its Size: text, as grade-run's nest.dxf):
  --size NAME converts that size alone. Without it the .svg output nests every size (the
  sample size in black) and the .dxf output keeps every size in ASTM's multi-size form;
  a .json output (one pattern) needs --size, and the error lists the sizes.

graded DXF (a base size whose grade points carry '# n' rule numbers, as grade-run's
graded.dxf) with its RUL grade-rule table: --rul RULES.rul grades the base to every size of
the table, which then converts as a multi-size DXF (--size NAME for one). The table is
never looked for on its own.

DXF has no stitches and no 3D placement. They are kept in a seams sidecar beside the
DXF, <name>.seams.json (for <name>.dxf, <name>.aama.dxf and <name>.astm.dxf):
  * reading a DXF uses --seams FILE, else the sidecar beside it if there is one;
  * --propose-seams FILE writes proposed stitches (runs between corners of equal length
    whose notches line up), each "confirmed": false; set the right ones to true, fix or
    add others, and convert again with --seams FILE;
  * writing a DXF of a pattern with stitches or placements also writes its sidecar.
See docs/formats.md, "DXF" and "Seams sidecar".

seam allowance (DXF output): a cut line read from a DXF is written back as it was while
the seam line is unchanged; otherwise each edge's allowance measured on reading is used,
and --seam-allowance CM for every edge without one (also replacing the kept cut line).
"""


def register(subparsers) -> None:
    p = add_command(subparsers, "convert", EPILOG)
    p.add_argument("input", metavar="IN", type=Path, help="pattern .json (sewpat-1, GarmentCode) or .dxf")
    p.add_argument("--out", metavar="OUT", type=Path, default=None,
                   help="output file: .json (sewpat-1), .svg or .dxf (.aama.dxf, .astm.dxf)")
    p.add_argument("--dxf-flavor", choices=("aama", "astm"), default=None,
                   help="DXF output flavour (default: from OUT's name, else aama)")
    p.add_argument("--dxf-units", choices=("mm", "cm", "in", "m"), default=None,
                   help="units of a DXF input, overriding its header")
    p.add_argument("--dxf-out-units", choices=("mm", "in"), default="mm",
                   help="units of a DXF output (default mm)")
    p.add_argument("--size", metavar="NAME", default=None,
                   help="of a multi-size DXF input, convert this size (its pieces' Size: text)")
    p.add_argument("--rul", metavar="RULES.rul", type=Path, default=None,
                   help="grade a base DXF input by this RUL grade-rule table (the graded form: '# n' "
                        "rule numbers at its grade points); one pattern per size, as a multi-size DXF")
    p.add_argument("--seams", metavar="SEAMS.json", type=Path, default=None,
                   help="seams sidecar of a DXF input (default: <name>.seams.json beside it, if any)")
    p.add_argument("--propose-seams", metavar="SEAMS.json", type=Path, default=None,
                   help="write proposed stitches for the user to confirm (with the pattern's own "
                        "stitches, confirmed) to this sidecar file")
    p.add_argument("--seam-allowance", metavar="CM", type=float, default=None,
                   help="DXF output: seam allowance for edges without their own (see below)")
    p.add_argument("--corners", choices=("mitre", "square"), default="mitre",
                   help="DXF output: seam allowance corners mitred or squared (default mitre)")
    add_force_argument(p, "OUT (and its seams sidecar) when they exist")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..pattern import flavor_from_path
    from ..pattern import read_pattern_file
    from .checks import number

    if args.out is None and args.propose_seams is None:
        raise SeamfitError("give --out OUT (and/or --propose-seams SEAMS.json)")
    kind = output_kind(args.out) if args.out is not None else None
    if args.seam_allowance is not None:
        number("--seam-allowance", args.seam_allowance, allow_zero=True)
    inputs = [args.input, args.seams, args.rul]
    from ..pattern import sidecar_path
    if args.input.suffix.lower() == ".dxf":
        inputs.append(sidecar_path(args.input))
    outputs: list[Path] = []
    flavor = None
    if kind == "dxf":
        flavor = args.dxf_flavor or flavor_from_path(args.out) or "aama"
    if args.out is not None:
        outputs.append(args.out)
    for out in outputs + ([args.propose_seams] if args.propose_seams else []):
        check_not_an_input(out, inputs)
    # read (and check) before anything is written
    if args.input.suffix.lower() == ".dxf":
        from ..pattern import one_size
        from ..pattern import read_dxf_size_file
        sizes = read_dxf_size_file(args.input, dxf_units=args.dxf_units, seams=args.seams, size=args.size,
                                   rul=args.rul)
        if args.size is None and len(sizes.patterns) > 1 and kind in ("svg", "dxf"):
            return _all_sizes(sizes, args, kind, flavor, inputs)
        pattern, fmt = one_size(sizes, args.size), f"dxf-{sizes.flavor}"
    else:
        pattern, fmt = read_pattern_file(args.input, dxf_units=args.dxf_units, seams=args.seams, size=args.size,
                                         rul=args.rul)
    notes = (pattern.extra.get("source") or {}).get("notes", []) if fmt.startswith("dxf") else []
    if not args.quiet:
        for m in notes:
            print(f"seamfit convert: note: {m}", file=sys.stderr)
    written = []
    if args.propose_seams is not None:
        from ..pattern import propose_stitches, sidecar_dict, write_sidecar
        proposals = propose_stitches(pattern)
        with OutputSet(args.propose_seams.parent, inputs=inputs, force=args.force,
                       files=[args.propose_seams.name]) as tmp:
            write_sidecar(tmp / args.propose_seams.name, sidecar_dict(pattern, proposals))
        written.append(f"{args.propose_seams} ({len(pattern.stitches)} stitches, {len(proposals)} proposed)")
        if not args.quiet:
            for j, prop in enumerate(proposals):
                for w in prop.get("notch_warnings", []):
                    print(f"seamfit convert: warning: proposed stitch {len(pattern.stitches) + j} "
                          f"({prop['a']['panel']} / {prop['b']['panel']}): {w}", file=sys.stderr)
    if args.out is not None:
        written += write_pattern_files(pattern, args.out, inputs=inputs, force=args.force, flavor=flavor,
                                       units=args.dxf_out_units, seam_allowance_cm=args.seam_allowance,
                                       corners=args.corners, title=Path(args.input).name)
    if not args.quiet:
        print(f"{args.input}: {fmt}, {len(pattern.panels)} panels, {len(pattern.stitches)} stitches")
        for w in written:
            print(f"wrote {w}")
        if fmt.startswith("dxf") and not pattern.stitches and kind == "sewpat-1" and args.propose_seams is None:
            print("note: the DXF has no stitches; propose them with --propose-seams SEAMS.json, confirm "
                  "them there and convert with --seams SEAMS.json", file=sys.stderr)
    return 0


def _all_sizes(sizes, args, kind: str, flavor: str, inputs) -> int:
    """Every size of a multi-size DXF: nested in one SVG, or again in ASTM's multi-size form."""
    from ..pattern import flavor_from_path
    labels = sizes.labels
    base = labels.index(sizes.sample_size) if sizes.sample_size else 0
    patterns = [sizes.patterns[lab] for lab in labels]
    if args.propose_seams is not None:
        raise SeamfitError(f"{args.input}: --propose-seams works on one size of a multi-size DXF; "
                           f"choose one with --size NAME ({', '.join(labels)})")
    if kind == "dxf" and (flavor == "aama" and (args.dxf_flavor or flavor_from_path(args.out))
                          or args.seam_allowance is not None or args.dxf_out_units != "mm"):
        raise SeamfitError(f"{args.input}: every size goes out in DXF-ASTM's multi-size form, in mm, with the "
                           "seam allowances read; for --dxf-flavor aama, --seam-allowance or inch output choose "
                           f"one size with --size NAME ({', '.join(labels)})")
    out: Path = args.out
    with OutputSet(out.parent, inputs=inputs, force=args.force, files=[out.name]) as tmp:
        if kind == "svg":
            from ..pattern import write_svg
            order = [base] + [k for k in range(len(labels)) if k != base]
            write_svg(tmp / out.name, [patterns[k] for k in order], labels=[labels[k] for k in order],
                      title=Path(args.input).name)
        else:
            from ..pattern import write_size_run_dxf
            write_size_run_dxf(tmp / out.name, patterns, labels, base)
    if not args.quiet:
        for m in sizes.notes:
            print(f"seamfit convert: note: {m}", file=sys.stderr)
        print(f"{args.input}: dxf-{sizes.flavor}, {len(labels)} sizes ({', '.join(labels)}), "
              f"{len(patterns[base].panels)} panels each")
        print(f"wrote {out}" + (" (the sizes nested)" if kind == "svg" else " (DXF-ASTM, every size)"))
    return 0
