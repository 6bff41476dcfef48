"""Writing a benchmark's results page into docs/."""
from __future__ import annotations

import re
from pathlib import Path

from seamfit.fileio import atomic_write_text

# A value of the report in a page's hand-written text: a table on a line of its own, a number inline.
PLACEHOLDER = re.compile(r"<!-- (\w+) -->")


def write_page(path: Path, lines: list[str], notes: Path | None = None, notes_heading: str | None = None) -> None:
    """``lines`` as a markdown page at ``path``, with the hand-written notes file appended
    (under ``notes_heading`` when given)."""
    lines = list(lines)
    if notes is not None:
        lines += [""] + (([f"## {notes_heading}", ""]) if notes_heading else []) + [notes.read_text().rstrip()]
    atomic_write_text(path, "\n".join(lines) + "\n")
    print(f"wrote {path}")


def fill(text: str, values: dict[str, str]) -> str:
    """``text`` with every ``<!-- name -->`` replaced by ``values[name]``; a name with no value
    is an error, not a blank in the page."""
    missing = sorted(set(PLACEHOLDER.findall(text)) - values.keys())
    if missing:
        raise KeyError(f"the report computes no {', '.join(missing)}")
    return PLACEHOLDER.sub(lambda m: values[m.group(1)], text)


def table(head: list[str], rows: list[list[str]], align: str = "") -> str:
    """A markdown table; ``align``: a letter a column, ``r`` right-aligned, anything else
    (or a column past its end) left."""
    def line(cells):
        return "|" + "|".join(f" {c} " if c else " " for c in cells) + "|"
    rule = "|" + "".join("---:|" if a == "r" else "---|" for a in align.ljust(len(head)))
    return "\n".join([line(head), rule] + [line(r) for r in rows])
