"""Command line: ``seamfit`` / ``python -m seamfit``.

Every failure a user can cause ends with a one-line message naming what is wrong
and a nonzero exit code, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from .errors import SeamfitError

# Subcommand modules under seamfit.commands, in the order --help lists them.
COMMANDS = ("validate", "convert", "body", "mesh", "sdf", "drape", "grade", "grade_run", "batch")


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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the same cleanup runs (temporary output folders,
    half-written cache files) instead of the process dying where it stands."""


_sigterm_seen = False


def _on_sigterm(signum, frame):
    global _sigterm_seen
    _sigterm_seen = True      # a library may re-raise it as a plain KeyboardInterrupt (Ray's wait)
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return run_guarded(args.command, lambda: args.func(args))


def run_guarded(command: str, fn) -> int:
    """``fn()``'s exit code, with the errors a user can cause as one-line messages, and
    SIGTERM handled as Ctrl-C (see the exit codes in docs/cli.md)."""
    global _sigterm_seen
    _sigterm_seen = False
    installed, previous = _install_sigterm()
    try:
        return int(fn() or 0)
    except SeamfitError as exc:
        _print_errors(command, exc.lines())
        return 2
    except OSError as exc:                       # disk full, permissions, ... while writing
        where = f"{exc.filename}: " if exc.filename else ""
        _print_errors(command, [f"{where}{exc.strerror or exc}"])
        return 2
    except MemoryError:
        _print_errors(command, ["out of memory; try a larger --edge-length or spacing, or a "
                                "smaller input (docs/cli.md, Limits)"])
        return 2
    except KeyboardInterrupt as exc:
        if not (isinstance(exc, Terminated) or _sigterm_seen):
            print(f"seamfit {command}: interrupted (SIGINT)", file=sys.stderr)
            return 128 + signal.SIGINT
        print(f"seamfit {command}: terminated (SIGTERM)", file=sys.stderr)
        return 128 + signal.SIGTERM
    except Exception as exc:                     # a bug: one line, the traceback on request
        if os.environ.get("SEAMFIT_TRACEBACK"):
            raise
        print(f"seamfit {command}: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
              "(a bug in seamfit; SEAMFIT_TRACEBACK=1 shows where)", file=sys.stderr)
        return 3
    finally:
        if installed:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


MAX_ERROR_LINES = 10


def _print_errors(command: str, lines: list[str]) -> None:
    for line in lines[:MAX_ERROR_LINES]:
        print(f"seamfit {command}: error: {line}", file=sys.stderr)
    if len(lines) > MAX_ERROR_LINES:
        # validate checks input files; a batch manifest's problems have no such command
        hint = "" if command == "batch" else " (seamfit validate lists them all)"
        print(f"seamfit {command}: error: ... and {len(lines) - MAX_ERROR_LINES} more{hint}", file=sys.stderr)


def _install_sigterm():
    """The handler, where signals can be handled (the main thread); the one it replaced."""
    try:
        return True, signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:                           # not the main thread
        return False, None
