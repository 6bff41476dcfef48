"""What every subcommand shares: its parser's set-up (its help and description from one
table), the outcome options of the long commands, and the warning printer."""
from __future__ import annotations

import argparse
import sys

# Each subcommand's line in `seamfit --help` and the description atop its own --help.
ABOUT = {
    "validate": ("check a pattern (sewpat-1 / GarmentCode) or body (.obj/.ply) file",
                 "Check a pattern or body file and print a summary, or the problems found."),
    "convert": ("convert a pattern between sewpat-1, GarmentCode, DXF-AAMA/ASTM and SVG",
                "Convert a pattern file to another format, chosen by the output's extension."),
    "body": ("make bodies from measurements (OBJ/PLY + report)",
             "Make bodies of the sample bodies' mesh from measurements, and report how well each meets them."),
    "mesh": ("triangulate a pattern into a sewn-ready mesh (OBJ, SVG, report)",
             "Triangulate every panel of a pattern, with matching vertices along both sides of every stitch, "
             "and write the mesh, a drawing and a report."),
    "sdf": ("build a body's signed distance field (.npz + .json report)",
            "``seamfit sdf BODY --out PATH``: build a body's signed distance field."),
    "drape": ("sew a pattern and dress it on a body (OBJ, report, picture)",
              "Mesh a pattern, dress it on a body with the quasistatic simulator and write the draped "
              "garment, a report and a picture."),
    "grade": ("adjust a base pattern to a new body (pattern, nest SVG, drape, report)",
              "Compute the pattern that makes the garment fit TARGET the way the base pattern fits BASE "
              "(rule-free grading and made-to-measure)."),
    "grade-run": ("grade a base pattern to a whole size run (a folder per size, one nest, a summary)",
                  "Grade PATTERN, which fits B0, to every target body (smallest to largest) in one run: each "
                  "size starts from its neighbour's result and all share the base's precompute."),
    "batch": ("run a manifest of gradings on Ray (a folder per job, a summary, resumable)",
              "Grade every job of MANIFEST (JSON or CSV) on Ray: locally on this machine's cores and GPUs, "
              "or on a cluster with --address. Finished jobs are skipped on a rerun."),
}


def add_command(subparsers, name: str, epilog: str | None = None) -> argparse.ArgumentParser:
    """The parser of subcommand ``name``, its help and description from ABOUT; the
    description and ``epilog`` are shown as written (their line breaks kept)."""
    summary, description = ABOUT[name]
    return subparsers.add_parser(name, help=summary, description=description, epilog=epilog,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)


def add_outcome_options(p: argparse.ArgumentParser, stopped: str, written: str, pictures: str) -> None:
    """The options of the commands whose work may stop before it converges: --fail-unconverged
    (``stopped`` says when), --no-picture, --force and --quiet (``written``: what they write)."""
    from ..output_set import add_force_argument
    p.add_argument("--fail-unconverged", action="store_true",
                   help=f"exit 1 when {stopped} (the {written} are still written); default: exit 0 whenever "
                        f"the {written} are written")
    p.add_argument("--no-picture", action="store_true", help=f"do not write {pictures}")
    add_force_argument(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def warner(command: str, quiet: bool = False):
    """``warn(message)``: prints ``seamfit COMMAND: warning: message`` on stderr, unless ``quiet``."""
    def warn(message: str) -> None:
        if not quiet:
            print(f"seamfit {command}: warning: {message}", file=sys.stderr)
    return warn
