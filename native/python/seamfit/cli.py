"""Command line: ``seamfit`` / ``python -m seamfit``.

Every failure a user can cause ends with a one-line message naming what is wrong
and a nonzero exit code, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from .errors import SeamfitError

# Subcommand modules under seamfit.commands, in the order --help lists them.
COMMANDS = ("validate", "mesh", "sdf", "drape", "grade")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="seamfit",
        description="Rule-free sewing pattern adjustment: grade a base pattern to a new body.")
    parser.add_argument("--version", action="version", version=f"seamfit {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"seamfit.commands.{name}").register(sub)
    return parser


def _version() -> str:
    from . import __version__
    return __version__


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SeamfitError as exc:
        print(f"seamfit {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"seamfit {args.command}: interrupted", file=sys.stderr)
        return 130
