"""``seamfit grade-run PATTERN --base-body B0 --target-bodies B1 B2 ... --out DIR``: a size run.

Grades one base pattern to every target body in one go (or to a body per size of a size
chart, ``--size-chart``): each size starts from its neighbour's result and all share the
base's mesh, field and drape (seamfit.opt.size_run). Writes, as one set (into a temporary
folder beside DIR, then moved into place; an existing non-empty DIR only with --force):
  <size>/        per size, what ``seamfit grade`` writes (pattern.json, pattern.svg,
                 pattern.png, garment.obj, drape.png, report.json)
  nest.svg       every size nested on the base: base in black, sizes in colour
  nest.png       the same nest as a picture
  nest.dxf       every size in one DXF-ASTM file (one block per piece and size)
  graded.dxf     the base size with grade-rule numbers at its grade points, and
  graded.rul     the grade-rule table (ASTM D6673) of the landmark moves per size
  summary.json   per size: ease, seam mismatch, time, iterations; flagged jumps
  summary.csv    the same table for a spreadsheet
Exit code 0 when the results are written (1 with --fail-unconverged when a size stopped at
its budget), 2 on an error.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

from ..errors import SeamfitError
from ..output_set import OutputSet
from .grade import (PICTURES, _registered_target, add_grade_options, check_grade_options, settings_from_args,
                    write_graded)
from .parsing import add_command, warner

NEST_PICTURES = ("nest.png",)
EPILOG = "Options after --out are those of `seamfit grade` and apply to every size. See docs/cli.md."


def register(subparsers) -> None:
    p = add_command(subparsers, "grade-run", EPILOG)
    p.add_argument("pattern", metavar="PATTERN", type=Path, help="base pattern (sewpat-1, GarmentCode .json or .dxf)")
    p.add_argument("--base-body", metavar="B0", type=Path, required=True,
                   help="body the base pattern fits (.obj/.ply, metres, Z up, facing -Y)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--target-bodies", metavar="B", type=Path, nargs="+",
                     help="bodies to grade to, smallest to largest (each named by its file)")
    src.add_argument("--size-chart", metavar="FILE", type=Path,
                     help="a size table (Valentina .vst or seamfit measurements .json): a body is made for each "
                          "size (as `seamfit body` makes it) and graded to")
    p.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if missing)")
    add_grade_options(p, truth=False)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..body import checked_body, load_measurement_sets
    from ..opt import base_place, base_size_label
    from .checks import checked_pattern

    out = Path(args.out)
    check_grade_options(args)

    warn = warner("grade-run", args.quiet)

    # Every input is read and checked before any body is made or any size graded.
    base_pattern = checked_pattern(args.pattern, args.edge_length, warn)
    base_body = checked_body(args.base_body, warn)
    if args.target_bodies is not None:
        _no_repeats(args.target_bodies)
        targets = [(Path(b).stem, checked_body(b, warn)) for b in args.target_bodies]
        sets = None
    else:
        sets = load_measurement_sets(args.size_chart)
        targets = [(s.name, None) for s in sets]
    labels = [lab for lab, _ in targets]
    if len(set(labels)) != len(labels):
        raise SeamfitError(f"{args.size_chart or 'target bodies'}: two sizes share a name "
                           f"({', '.join(labels)}); give each size its own name")
    settings = settings_from_args(args, base_pattern)
    inputs = [args.pattern, args.base_body, *(args.target_bodies or []), args.size_chart]
    with OutputSet(out, inputs=inputs, force=args.force) as tmp:
        if sets is not None:
            targets = _chart_bodies(args, sets)
        targets = [(lab, _on_base_mesh(args, base_body, body, lab)) for lab, body in targets]
        base_label = base_size_label(args.base_body.stem, labels)
        base_index = base_place(base_body, targets, warn)
        summary = _run(args, settings, base_pattern, base_body, targets, base_index, base_label, tmp)
    if not args.quiet:
        print(f"wrote {out}/ ({len(targets)} sizes), nest.svg, nest.dxf, graded.dxf, graded.rul, summary.json, "
              "summary.csv", file=sys.stderr)
    unconverged = [r["size"] for r in summary["sizes"] if not r.get("base") and not r["converged"]]
    if unconverged and not args.quiet:
        print(f"seamfit grade-run: {', '.join(unconverged)} stopped before converging; the results are written "
              "and their report.json says so", file=sys.stderr)
    return 1 if args.fail_unconverged and unconverged else 0


def _no_repeats(paths) -> None:
    seen = {}
    for p in paths:
        key = Path(p).resolve()
        if key in seen:
            raise SeamfitError(f"{p}: given twice in --target-bodies")
        seen[key] = p


def _chart_bodies(args, sets) -> list:
    from ..body import from_measurements
    out = []
    for s in sets:
        if not args.quiet:
            print(f"seamfit grade-run: making the body of {s.where}", file=sys.stderr)
        out.append((s.name, from_measurements(s).body))
    return out


def _on_base_mesh(args, base_body, body, label):
    """The target on the base body's mesh (registered onto it when it has another)."""
    ns = argparse.Namespace(**{**vars(args), "target_body": label})
    body, _ = _registered_target(ns, base_body, body, command="grade-run")
    return body


def _folder_names(labels: list[str]) -> list[str]:
    names, used = [], set()
    for lab in labels:
        stem = re.sub(r"[^A-Za-z0-9._-]+", "_", lab).strip("._") or "size"
        name, j = stem, 2
        while name.lower() in used or name.lower() in ("nest", "summary", "graded"):
            name, j = f"{stem}_{j}", j + 1
        used.add(name.lower())
        names.append(name)
    return names


def _run(args, settings, base_pattern, base_body, targets, base_index, base_label, tmp: Path) -> dict:
    import time
    from ..fileio import atomic_write_text, json_default
    from ..opt import run_sizes, summary_row
    from ..pictures import draw_pictures, skipped
    from ..progress import ConsoleProgress, for_grading

    t0 = time.perf_counter()
    labels = [lab for lab, _ in targets]
    row = labels[:base_index] + [base_label] + labels[base_index:]
    folders = dict(zip(row, _folder_names(row)))
    bodies = dict(targets)
    rows: dict[str, dict] = {}
    progress: dict = {}

    def progress_for(label):
        if args.quiet:
            return None
        print(f"seamfit grade-run: size {label}", file=sys.stderr)
        progress[label] = ConsoleProgress(for_grading(
            base_pattern, settings, writing=True, pictures=0 if args.no_picture else len(PICTURES)))
        return progress[label]

    def on_size(done):
        folder = tmp / folders[done.label]
        folder.mkdir()
        size_args = argparse.Namespace(**{**vars(args), "target_body": Path(done.label), "truth": None})
        extra = {"size_run": {"size": done.label, "warm_start_from": done.warm_from, "seconds": done.seconds}}
        report = write_graded(size_args, done.result, progress.get(done.label), base_pattern, base_body,
                              bodies[done.label], None, folder, extra_report=extra)
        rows[done.label] = summary_row(done.label, report, warm_from=done.warm_from, seconds=done.seconds,
                                       folder=folders[done.label])

    try:
        run = run_sizes(base_pattern, base_body, targets, base_index, settings, base_label=base_label,
                        on_size=on_size, progress_for=progress_for)
    except BaseException:
        for p in progress.values():
            p.fail()
        raise
    patterns = run.patterns(base_pattern)
    for lab, pat in zip(run.labels, patterns):
        pat.body_id = lab if pat is not base_pattern else pat.body_id
    name = base_pattern.garment_id or args.pattern.stem
    _write_nest(tmp, patterns, run.labels, base_index, name, args)
    summary = {
        "pattern": str(args.pattern), "base_body": str(args.base_body), "base_size": base_label,
        "order": run.labels,
        "sizes": [({"size": lab, "folder": None, "base": True} if k == base_index else rows[lab])
                  for k, lab in enumerate(run.labels)],
        "jumps": run.jumps,
        "seconds_total": round(time.perf_counter() - t0, 2),
        "seconds_grading": round(run.seconds, 2),
    }
    if args.no_picture:
        summary["pictures"] = skipped(NEST_PICTURES)
    else:
        def nest(path):
            from ..pattern import render_nest_png
            render_nest_png(path, _nest_order(patterns, base_index), labels=_nest_order(run.labels, base_index),
                            title=f"{name}: graded nest of {len(patterns)} sizes")
        summary["pictures"] = draw_pictures(tmp, {"nest.png": nest}, command="grade-run")
    atomic_write_text(tmp / "summary.json", json.dumps(summary, indent=1, default=json_default) + "\n")
    atomic_write_text(tmp / "summary.csv", _csv(summary))
    if not args.quiet:
        print(_table(summary), file=sys.stderr)
    for r in summary["sizes"]:   # even with -q: a size that came out tighter than its base needs a look
        for line in r.get("ease_losses") or []:
            print(f"seamfit grade-run: warning: {r['size']}: {line}", file=sys.stderr)
    for j in run.jumps:          # even with -q: a size that jumps needs a look before cutting
        print(f"seamfit grade-run: warning: {j['panel']} {j['landmark']} moves back {j['back_mm']:.1f} mm from "
              f"{j['from']} to {j['to']} (out of size order)", file=sys.stderr)
    return summary


def _nest_order(items, base_index):
    """The base first (drawn black), then the sizes in order."""
    return [items[base_index]] + [x for k, x in enumerate(items) if k != base_index]


def _write_nest(tmp: Path, patterns, labels, base_index, name, args) -> None:
    from ..pattern import write_svg
    from ..pattern import write_graded_dxf, write_size_run_dxf
    nest, nest_labels = _nest_order(patterns, base_index), _nest_order(labels, base_index)
    write_svg(tmp / "nest.svg", nest, labels=nest_labels, title=f"{name}: graded nest of {len(patterns)} sizes")
    write_size_run_dxf(tmp / "nest.dxf", patterns, labels, base_index)
    write_graded_dxf(tmp / "graded.dxf", tmp / "graded.rul", patterns, labels, base_index)


_LEVELS = ("bust", "waist", "hip")


def _csv(summary: dict) -> str:
    head = ["size", "base", *(f"ease_{lv}_cm" for lv in _LEVELS), "seam_mismatch_max_mm", "seam_mismatch_mean_mm",
            "seconds", "outer_iterations", "converged", "warm_start_from", "jumps"]
    lines = [",".join(head)]
    for r in summary["sizes"]:
        n_jumps = sum(1 for j in summary["jumps"] if j["to"] == r["size"])
        if r.get("base"):
            cells = [r["size"], "yes"] + [""] * (len(head) - 3) + [str(n_jumps)]
        else:
            ease, seam = r["ease_cm"], r["seam_mismatch_mm"]
            cells = [r["size"], "no", *("" if ease.get(lv) is None else f"{ease[lv]:g}" for lv in _LEVELS),
                     "" if seam["max"] is None else f"{seam['max']:g}", "" if seam["mean"] is None else f"{seam['mean']:g}",
                     f"{r['seconds']:g}", str(r["outer_iterations"]), "yes" if r["converged"] else "no",
                     r["warm_start_from"] or "", str(n_jumps)]
        lines.append(",".join(_csv_cell(c) for c in cells))
    return "\n".join(lines) + "\n"


def _csv_cell(c: str) -> str:
    return f'"{c}"' if any(ch in c for ch in ',"\n') else c


def _table(summary: dict) -> str:
    out = [f"{'size':<16} {'ease bust/waist/hip cm':>24} {'seam max mm':>11} {'s':>7} {'it':>4}  from"]
    for r in summary["sizes"]:
        if r.get("base"):
            out.append(f"{r['size']:<16} {'(base)':>24}")
            continue
        e = r["ease_cm"]
        ease = "/".join("-" if e.get(lv) is None else f"{e[lv]:.1f}" for lv in _LEVELS)
        seam = r["seam_mismatch_mm"]["max"]
        out.append(f"{r['size']:<16} {ease:>24} {'-' if seam is None else f'{seam:.2f}':>11} {r['seconds']:>7.1f} "
                   f"{r['outer_iterations']:>4}  {r['warm_start_from'] or '-'}")
    return "\n".join(out)
