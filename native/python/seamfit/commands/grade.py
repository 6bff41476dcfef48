"""``seamfit grade PATTERN --base-body B0 --target-body B1 --out DIR``: the main job.

Writes, as one set (into a temporary folder beside DIR, then moved into place; an
existing non-empty DIR is replaced whole, only with --force; no input is ever touched):
  pattern.json   the adjusted pattern (sewpat-1, same panels, stitches and landmarks,
                 curves refitted to the moved boundary)
  pattern.svg    the graded nest: base pattern in black, adjusted pattern in colour
  pattern.png    the same nest as a picture
  garment.obj    the final drape on the target body (vt = adjusted pattern, cm)
  drape.png      front, side and back views of that drape
  report.json    objectives and terms before/after, iterations, timings, checks, ease
The pictures are drawn last; one that cannot be drawn (no matplotlib, a drawing error) is
a warning and a ``pictures`` entry in the report, and the other files are still written.
Exit code 0 when the results are written, converged or not (the report and the console
say which; --fail-unconverged makes a stop at the budget exit 1), 2 on an error.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..grade_files import PICTURES
from ..output_set import OutputSet
from ..pictures import written
from .parsing import add_command, add_outcome_options, warner

EPILOG = """\
Presets (strengths fix, cur, dis, smo, str, pos from the paper's Table 1; seam, the
seam-length term, is ours, see docs/optimizer.md):
  auto            by the pattern's garment_type: skirt, pants, fitted or dress (default)
  dress           woven garments with ease: dresses, tops, jackets
  skirt           skirts: the dress's balance without the positional cost (ours)
  fitted          stretch garments worn under tension (bodysuit, leggings)
  skirt_shirring  gathered or shirred garments
  pants           trousers and jumpsuits
Methods (--method; every result is scored with the same objective and report):
  adjoint         the paper's Algorithm 1: adjoint gradient on the whole objective (default)
  two-phase       baseline (paper Sec. 3): transfer the garment, then the same optimizer
                  on the positional cost only (plus the boundary regularizers)
  fixed-point     baseline (paper Sec. 8.1, after Bartle et al. 2016): drape, move each
                  pattern triangle towards the transferred garment's, repeat
See docs/method.md for the method, docs/grading.md for the baselines and docs/cli.md for examples.
"""


def register(subparsers) -> None:
    p = add_command(subparsers, "grade", EPILOG)
    p.add_argument("pattern", metavar="PATTERN", type=Path, help="base pattern (sewpat-1, GarmentCode .json or .dxf)")
    p.add_argument("--base-body", metavar="B0", type=Path, required=True,
                   help="body the base pattern fits (.obj/.ply, metres, Z up, facing -Y)")
    p.add_argument("--target-body", metavar="B1", type=Path, required=True,
                   help="body to grade to: the base body's mesh in another shape, or any body mesh (a scan, "
                        "a character), which is registered onto the base body's mesh first")
    p.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if missing)")
    add_grade_options(p, truth=True)
    p.set_defaults(func=run)


def add_grade_options(p, *, truth: bool) -> None:
    """The search, mesh, field, device and output options, defined once for ``grade``,
    ``grade-run`` and the batch jobs (the settings from seamfit.settings' table; ``truth``:
    also --truth, a pattern drafted for the one target)."""
    from .. import settings
    from ..opt import STRENGTH_NAMES
    settings.add_options(p, "grade")
    for name in STRENGTH_NAMES:
        p.add_argument(f"--{name}", type=float, default=None, metavar="DELTA",
                       help=f"override the preset's {name} strength " +
                            ("(> 0: R^fix also shapes the search's preconditioner)" if name == "fix"
                             else "(0 skips the term)"))
    if truth:
        p.add_argument("--truth", metavar="PATTERN", type=Path, default=None,
                       help="a pattern drafted for the target body: report landmark errors against it")
    add_outcome_options(p, "a search stopped at its budget before converging", "results", "drape.png and pattern.png")


def run(args) -> int:
    from ..pattern import load_pattern
    from ..body import checked_body
    from .checks import checked_pattern

    out = Path(args.out)
    # Options, inputs and --truth are checked before any meshing, drape or search.
    check_grade_options(args)

    warn = warner("grade", args.quiet)

    base_pattern = checked_pattern(args.pattern, args.edge_length, warn)
    truth = None
    if args.truth is not None:
        from ..pattern import baseline_errors
        truth_pattern = load_pattern(args.truth)
        # scored against the base now: a truth with no panel in common fails here, not after the search
        truth = (truth_pattern, baseline_errors(base_pattern, truth_pattern).to_dict())
    base_body = checked_body(args.base_body, warn)
    target_body = checked_body(args.target_body, warn)
    target_body, registration = _registered_target(args, base_body, target_body)
    settings = settings_from_args(args, base_pattern)
    if not args.no_picture:   # matplotlib loads while the body fields are built (seamfit.preload)
        from .. import preload
        preload.want("matplotlib.pyplot")
    # Named stages, the share done and the time left: a bar on a terminal, plain lines in
    # a log (seamfit.progress); -q: none.
    from ..progress import ConsoleProgress, for_grading
    progress = None if args.quiet else ConsoleProgress(for_grading(
        base_pattern, settings, writing=True, pictures=0 if args.no_picture else len(PICTURES)))

    inputs = [args.pattern, args.base_body, args.target_body, args.truth]
    try:
        with OutputSet(out, inputs=inputs, force=args.force) as tmp:
            report = _grade(args, settings, progress, base_pattern, base_body, target_body, truth, tmp,
                            registration)
    except BaseException:
        if progress is not None:
            progress.fail()     # the error's line starts on a line of its own
        raise
    if not args.quiet:
        pics = "".join(f", {name}" for name in written(report["pictures"]))
        print(f"wrote {out}/pattern.json, pattern.svg, garment.obj, report.json{pics}", file=sys.stderr)
    if not report["converged"] and not args.quiet:
        print(f"seamfit grade: stopped before converging ({report['message']}); the results are written and "
              "report.json says so", file=sys.stderr)
    return 1 if args.fail_unconverged and not report["converged"] else 0


def check_grade_options(args) -> None:
    """The options of :func:`add_grade_options`, checked before any input is read."""
    from ..device import check_device
    check_device(args.device)  # fails at once, with the reason, when cuda cannot run here
    check_grade_numbers(args)


def check_grade_numbers(args) -> None:
    """The options of :func:`add_grade_options`, each against its setting's range (also the
    batch script's, which resolves its device inside Blender)."""
    from .. import settings
    settings.check_options(args, "grade")
    _strength_overrides(args)


def settings_from_args(args, base_pattern):
    """The GradeSettings the options of :func:`add_grade_options` ask for, validated."""
    from dataclasses import replace

    from .. import settings as seamfit_settings
    from .. import GradeSettings
    from ..opt import preset
    strengths = preset(args.preset, base_pattern.garment_type).strengths
    overrides = _strength_overrides(args)
    if overrides:
        strengths = replace(strengths, **overrides)
    values = seamfit_settings.from_options(args, "grade", "grade")
    settings = GradeSettings(**{**values, "strengths": strengths})
    settings.validate()
    return settings


def _strength_overrides(args) -> dict:
    """--fix ... --seam as given, each checked as the strengths themselves check it; --fix
    also > 0: R^fix shapes the search's preconditioner, which needs it positive definite."""
    from ..errors import SeamfitError
    from ..opt import STRENGTH_NAMES, Strengths
    overrides = {}
    for name in STRENGTH_NAMES:
        value = getattr(args, name)
        if value is None:
            continue
        try:
            Strengths(**{name: value})
        except ValueError as exc:
            raise SeamfitError(f"--{name} {value:g}: {exc}") from None
        if name == "fix" and not value > 0:
            raise SeamfitError(f"--fix {value:g}: must be > 0: R^fix also shapes the search's preconditioner, "
                               "which needs it positive (a small value such as 0.001 weakens the term)")
        overrides[name] = value
    return overrides


def _registered_target(args, base_body, target_body, *, command: str = "grade"):
    """The target on the base body's mesh: itself when it shares that mesh, else registered
    onto it (seamfit.body.register; its checks fail at once, before any fitting)."""
    from ..body import check_frame, check_registrable, same_topology, target_for
    if same_topology(base_body, target_body):
        check_frame(target_body)            # not registered, but a body lying down (Y-up) is refused now
        return target_body, None
    check_registrable(target_body)
    if not args.quiet:
        print(f"seamfit {command}: {args.target_body} has another mesh than the base body ({target_body.n_vertices} "
              f"vertices, {base_body.n_vertices} in {args.base_body}): registering the base body's mesh onto it",
              file=sys.stderr)
    body, reg = target_for(base_body, target_body)
    if not args.quiet:
        print(f"seamfit {command}: registered: {reg.mean_mm:.1f} mm mean, {reg.max_mm:.1f} mm max from the target's "
              f"surface ({reg.seconds:.1f} s)", file=sys.stderr)
    return body, reg


def _grade(args, settings, progress, base_pattern, base_body, target_body, truth, tmp: Path,
           registration=None) -> dict:
    """Grade, then write the set into ``tmp`` (moved to --out afterwards); the report."""
    from .. import grade
    result = grade(base_pattern, base_body, target_body, settings, progress=progress)
    return write_graded(args, result, progress, base_pattern, base_body, target_body, truth, tmp, registration)


def write_graded(args, result, progress, base_pattern, base_body, target_body, truth, tmp: Path,
                 registration=None, *, extra_report: dict | None = None) -> dict:
    """What ``seamfit grade`` writes for one graded result, into the folder ``tmp``; the
    report (``extra_report`` added to it: a size run's entries)."""
    from ..grade_files import write_grade_files

    if progress is not None:
        progress.enter("writing")
    report = dict(result.report)
    report["inputs"] = {"pattern": str(args.pattern), "base_body": str(args.base_body),
                        "target_body": str(args.target_body)}
    if registration is not None:        # the target the grading used: the base mesh fitted onto it
        report["registration"] = registration.report()
    report.update(extra_report or {})
    if truth is not None:
        from ..pattern import landmark_errors
        truth_pattern, base_unchanged = truth
        report["accuracy"] = {"truth": str(args.truth),
                              "graded": landmark_errors(result.pattern, truth_pattern).to_dict(),
                              "base_unchanged": base_unchanged,
                              "proportional_scaling": _scaled_errors(base_pattern, base_body, target_body,
                                                                     truth_pattern)}

    result.pattern.body_id = target_body.name
    report = write_grade_files(tmp, result, base_pattern, report, base_name=base_body.name,
                               target_name=target_body.name, target_body=target_body,
                               title=base_pattern.garment_id or args.pattern.stem, pictures=not args.no_picture)
    if progress is not None:
        progress.close()
    if (report.get("sdf") or {}).get("warning"):  # even with -q: collisions may have been missed
        print(f"seamfit grade: warning: {report['sdf']['warning']}", file=sys.stderr)
    for line in (report.get("ease_cm") or {}).get("losses") or []:    # even with -q: the fit changed
        print(f"seamfit grade: warning: {line}", file=sys.stderr)
    for which in ("base", "target"):   # a body field the GPU handed to the CPU (slower, not wrong)
        note = ((report.get("sdf") or {}).get(which) or {}).get("device_note")
        if note and not args.quiet:
            print(f"seamfit grade: note: the {which} body's field was {note}", file=sys.stderr)
    if not args.quiet:
        r = report
        c = r.get("coarse_level")
        if c and "skipped" in c:
            print(f"seamfit grade: note: {c['skipped']}", file=sys.stderr)
            c = None
        if c:
            print(f"{r['method']}: graded on the coarse level ({c['edge_length_cm']:g} cm, {c['vertices']} vertices): "
                  f"objective {c['objective_initial']:.4g} -> {c['objective_final']:.4g} in {c['outer_iterations']} "
                  f"iterations, {c['seconds']:.1f} s; carried to this mesh ({r['mesh']['vertices']} vertices)",
                  file=sys.stderr)
        if c and not r["outer_iterations_done"]:
            print(f"{r['method']}: {r['seconds_total']:.1f} s; max pattern change {r['max_displacement_mm']:.1f} mm",
                  file=sys.stderr)
        else:
            print(f"{r['method']}: objective {r['objective_initial']:.4g} -> {r['objective_final']:.4g} "
                  f"({100 * r['objective_reduction']:.1f} % lower) in {r['outer_iterations']} iterations, "
                  f"{r['seconds_total']:.1f} s; max pattern change {r['max_displacement_mm']:.1f} mm", file=sys.stderr)
        _print_time_split(r)
        print(progress.stages_line(), file=sys.stderr)
        ease = r.get("ease_cm") or {}
        if any(v is not None for v in (ease.get("result") or {}).values()):
            print(f"ease bust / waist / hip: {_ease_cells(ease.get('result'))} cm on {target_body.name} "
                  f"(base garment on {base_body.name}: {_ease_cells(ease.get('base'))} cm)", file=sys.stderr)
        if "accuracy" in r:
            acc = r["accuracy"]
            scaled = acc["proportional_scaling"]
            scaled = f", proportional scaling: {scaled['max_cm']:.2f} cm" if scaled.get("max_cm") is not None else ""
            print(f"landmark error vs truth: max {acc['graded']['max_cm']:.2f} cm "
                  f"(unchanged base: {acc['base_unchanged']['max_cm']:.2f} cm{scaled})", file=sys.stderr)
    return report


def _ease_cells(ease: dict | None) -> str:
    return " / ".join("-" if (ease or {}).get(k) is None else f"{ease[k]:+.1f}" for k in ("bust", "waist", "hip"))


def _scaled_errors(base_pattern, base_body, target_body, truth_pattern) -> dict:
    """The simplest grading a pattern maker could do by hand, scored on the same truth: each
    panel scaled by the bodies' girth ratio across and height ratio along
    (seamfit.pattern.scale), from the bodies' own measurements."""
    from ..body import body_measurements
    from ..errors import SeamfitError
    from ..pattern import landmark_errors
    from ..pattern import proportional_scale
    try:
        m0, m1 = body_measurements(base_body), body_measurements(target_body)
        scaled, ratios = proportional_scale(base_pattern, m0, m1)
        return {**landmark_errors(scaled, truth_pattern).to_dict(), "ratios": ratios}
    except SeamfitError as exc:      # a body that cannot be measured costs only this baseline
        return {"max_cm": None, "error": str(exc)}


def _print_time_split(r: dict) -> None:
    """Where the outer loop's time went, on which device (Algorithm 1's report only)."""
    sp = r.get("seconds_loop_split")
    if not sp:
        return
    adj = r.get("adjoint") or {}
    extra = ""
    if adj.get("device") == "cuda" and adj.get("solves"):
        extra = f", MINRES {adj['minres_iterations'] / adj['solves']:.0f} iterations per solve"
        if adj.get("truncated") or adj.get("gpu_fallbacks"):
            extra += f": {adj.get('truncated', 0)} kept at the budget, {adj.get('gpu_fallbacks', 0)} redone on the CPU"
    print(f"device {r['device']}: simulation {sp['simulation']:.1f} s, gradient {sp['gradient']:.1f} s "
          f"(adjoint {sp.get('factorizations', 0.0) + sp.get('adjoint_solves', 0.0):.1f} s{extra})", file=sys.stderr)
