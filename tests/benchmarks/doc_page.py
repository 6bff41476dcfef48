"""Writing a benchmark's results page into docs/."""
from __future__ import annotations

from pathlib import Path

from seamfit.fileio import atomic_write_text


def write_page(path: Path, lines: list[str], notes: Path | None = None, notes_heading: str | None = None) -> None:
    """``lines`` as a markdown page at ``path``, with the hand-written notes file appended
    (under ``notes_heading`` when given)."""
    lines = list(lines)
    if notes is not None:
        lines += [""] + (([f"## {notes_heading}", ""]) if notes_heading else []) + [notes.read_text().rstrip()]
    atomic_write_text(path, "\n".join(lines) + "\n")
    print(f"wrote {path}")
