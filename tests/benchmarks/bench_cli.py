"""The command line the benchmarks share: subcommands that each name the function that
runs them, the report subcommand's arguments, and the case sweep's inputs."""
from __future__ import annotations

import argparse
import os
from pathlib import Path

DOCS = Path(__file__).resolve().parents[2] / "docs"
DATA = Path("/work/shared/data")


def threads_per_job(threads: int, jobs: int) -> int:
    """OpenMP threads for each of ``jobs`` concurrent runs: ``threads`` when given (> 0), else
    the cores shared out (at least one), so that concurrent runs do not oversubscribe them."""
    return threads or max(1, (os.cpu_count() or 1) // jobs)


class Commands:
    """A parser of subcommands (run, report, ...); ``main`` parses argv and calls the one named."""

    def __init__(self, description: str | None = None, **kw):
        self.parser = argparse.ArgumentParser(description=description,
                                              formatter_class=argparse.RawDescriptionHelpFormatter, **kw)
        self._sub = self.parser.add_subparsers(dest="cmd", required=True)

    def add(self, name: str, func, **kw) -> argparse.ArgumentParser:
        p = self._sub.add_parser(name, **kw)
        p.set_defaults(func=func)
        return p

    def add_run(self, func, **kw) -> argparse.ArgumentParser:
        """The run subcommand: its results go to --out."""
        p = self.add("run", func, **kw)
        p.add_argument("--out", type=Path, required=True)
        return p

    def add_report(self, func, nargs: str | None = "+", notes: str | None = None, **kw) -> argparse.ArgumentParser:
        """The report subcommand: results files in, a page under --docs; ``notes``, when given,
        is the help of --notes (a markdown file the page appends)."""
        p = self.add("report", func, **kw)
        p.add_argument("results", type=Path, nargs=nargs)
        p.add_argument("--docs", type=Path, default=DOCS)
        if notes is not None:
            p.add_argument("--notes", type=Path, default=None, help=notes)
        return p

    def main(self, argv=None) -> int:
        args = self.parser.parse_args(argv)
        return args.func(args)


def add_sweep(p: argparse.ArgumentParser, bodies: bool = True, jobs_help: str | None = None) -> None:
    """The inputs of a sweep over (garment, body) cases of the data folder, run ``--jobs`` at once;
    ``bodies``: the target bodies can be chosen too."""
    p.add_argument("--data", type=Path, default=DATA, help=f"data folder with patterns/ and bodies/ (default {DATA})")
    p.add_argument("--jobs", type=int, default=1, help=jobs_help)
    p.add_argument("--garments", default=None, help="comma list (default all)")
    if bodies:
        p.add_argument("--bodies", default=None, help="comma list of target bodies (default all but the base)")

