"""``seamfit body --measurements FILE --out PATH``: make bodies from measurements;
``seamfit body --register SCAN --out BODY.obj``: fit the sample bodies' mesh onto a body
mesh of another topology (a scan, a character), for grading to it.

FILE holds one body or several (seamfit JSON, a Seamly2D / Valentina individual .vit or a
multi-size .vst, one body per size). With --out BODY.obj (or .ply) the one body is
written there with its report beside it (BODY.report.json); with --out DIR every body is
written as DIR/<name>.obj with DIR/report.json. The report lists, per body, which
measurements were set and which inferred, requested against achieved values, and why
any value is missed by more than 0.5 cm. With --register the report (BODY.report.json)
gives the registration error: mean and largest distance from the body to the scan's
surface and back, in mm (seamfit.body.register).
"""
from __future__ import annotations

import json
import re
import sys
import time
from pathlib import Path

from ..errors import SeamfitError
from ..output_set import OutputSet, add_force_argument
from .parsing import add_command

EPILOG = """\
Measurements (cm unless the file says otherwise): height, bust, underbust, waist, hip,
shoulder, nape_to_waist, waist_to_hip, upper_arm, thigh, neck, inseam; any subset. The
rest follow the body model (MakeHuman hm08, CC0). See docs/bodies.md.

seamfit JSON: {"units": "cm", "gender": "female", "measurements": {"height": 165, "bust": 90}}
or several bodies: {"units": "cm", "bodies": {"anna": {"measurements": {...}}, ...}}.
"""
BODY_SUFFIXES = (".obj", ".ply")


def register(subparsers) -> None:
    p = add_command(subparsers, "body", EPILOG)
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--measurements", metavar="FILE", type=Path,
                        help="seamfit .json, Seamly2D/Valentina .vit (one body) or .vst (one body per size)")
    source.add_argument("--register", metavar="SCAN", type=Path,
                        help="a body mesh of another topology (.obj/.ply, metres, Z up, facing -Y, standing "
                             "in an A-pose): fit the sample bodies' mesh onto it")
    p.add_argument("--out", metavar="PATH", type=Path, required=True,
                   help="BODY.obj / BODY.ply for one body (report beside it), or a folder (--measurements)")
    p.add_argument("--gender", choices=("female", "male"), default=None,
                   help="the body model's gender (default: the file's, else female)")
    add_force_argument(p, "the body and its report, or the --out folder,")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..body import from_measurements, load_measurement_sets, save_body
    from ..fileio import atomic_write_text

    if args.register is not None:
        return _run_register(args)
    t0 = time.perf_counter()
    sets = load_measurement_sets(args.measurements)       # every value checked before any work
    out = Path(args.out)
    single = out.suffix.lower() in BODY_SUFFIXES
    if single and len(sets) != 1:
        raise SeamfitError(f"{args.measurements}: holds {len(sets)} bodies "
                           f"({', '.join(s.name for s in sets)}); give --out a folder")
    if single:
        names = [out.name]
        report_name = out.stem + ".report.json"   # not BODY.json: often the measurements' own name
        output = OutputSet(out.parent, inputs=[args.measurements], force=args.force,
                           files=[out.name, report_name])
    else:
        names = _file_names([s.name for s in sets])
        report_name = "report.json"
        output = OutputSet(out, inputs=[args.measurements], force=args.force)
    reports = []
    with output as tmp:
        for mset, file_name in zip(sets, names):
            made = from_measurements(mset, gender=args.gender)
            save_body(made.body, tmp / file_name)
            r = made.report()
            r["file"] = file_name
            r["ignored"] = list(mset.ignored)
            reports.append(r)
            if not args.quiet:
                _print_body(out if single else out / file_name, r)
        report = {"measurements": str(args.measurements), "units": "cm",
                  "model": "MakeHuman hm08 base mesh and targets (CC0, via MPFB2)",
                  "bodies": reports, "seconds": round(time.perf_counter() - t0, 3)}
        atomic_write_text(tmp / report_name, json.dumps(report, indent=1) + "\n")
    if not args.quiet:
        print(f"wrote {len(reports)} bod{'y' if len(reports) == 1 else 'ies'} and "
              f"{out.parent / report_name if single else out / report_name}")
    return 0


def _run_register(args) -> int:
    from ..body import check_registrable, load_body, register_body, save_body
    from ..fileio import atomic_write_text

    out = Path(args.out)
    if out.suffix.lower() not in BODY_SUFFIXES:
        raise SeamfitError(f"{out}: --register writes one body: give --out BODY.obj or BODY.ply")
    report_name = out.stem + ".report.json"
    output = OutputSet(out.parent, inputs=[args.register], force=args.force, files=[out.name, report_name])
    output.check_inputs()
    output.check_existing()
    scan = load_body(args.register)
    check_registrable(scan)                       # the reasons it cannot be registered, before any fitting
    if not args.quiet:
        print(f"registering {args.register} ({scan.n_vertices} vertices) onto the sample bodies' mesh ...",
              file=sys.stderr)
    reg = register_body(scan, gender=args.gender or "female", name=out.stem)
    with output as tmp:
        save_body(reg.body, tmp / out.name)
        report = {"registration": reg.report(), "file": out.name}
        atomic_write_text(tmp / report_name, json.dumps(report, indent=1) + "\n")
    if not args.quiet:
        print(f"{out}: registration error {reg.mean_mm:.1f} mm mean, {reg.max_mm:.1f} mm max to the scan's surface "
              f"(scan to body: {reg.scan_mean_mm:.1f} mm mean, {reg.scan_max_mm:.1f} mm max); {reg.seconds:.1f} s")
        print(f"wrote {out} and {out.parent / report_name}")
    return 0


def _print_body(path: Path, r: dict) -> None:
    print(f"{path}: {len(r['set'])} measurements set, {len(r['inferred'])} inferred "
          f"({', '.join(r['inferred']) or 'none'}); max error {r['max_error_cm']:.2f} cm, "
          f"{r['fit']['seconds']:.1f} s")
    for line in r["problems"]:
        print(f"seamfit body: warning: {r['name']}: {line}", file=sys.stderr)


def _file_names(names: list[str]) -> list[str]:
    """A distinct, file-safe BODY.obj name per body."""
    out, seen = [], set()
    for n in names:
        base = re.sub(r"[^A-Za-z0-9_.-]+", "_", n).strip("._") or "body"
        name, k = base, 1
        while name in seen:
            k += 1
            name = f"{base}_{k}"
        seen.add(name)
        out.append(name + ".obj")
    return out
