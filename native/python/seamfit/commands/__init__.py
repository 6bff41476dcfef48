"""CLI subcommands, one module each. Every module exposes ``register(subparsers)``,
which adds its parser and sets ``func(args) -> int`` as the handler.

For scripts that take ``seamfit grade``'s own options (the Blender batch script), the
public part: ``grade_parser`` and ``check_grade_numbers``."""

from .grade import check_grade_numbers

__all__ = ["check_grade_numbers", "grade_parser"]


def grade_parser(prog: str):
    """``seamfit grade``'s argument parser, standalone, shown as ``prog``."""
    import argparse

    from . import grade
    subparsers = argparse.ArgumentParser(prog=prog).add_subparsers(dest="command")
    grade.register(subparsers)
    parser = subparsers.choices["grade"]
    parser.prog = prog
    return parser
