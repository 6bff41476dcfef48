"""Every results page with data in docs/results/data/ is what its benchmark's report writes
from that data: each `report` command that the data README lists is run into a scratch
folder, and the page it writes must equal the committed one byte for byte. Pictures are
only checked to exist: their bytes change with the matplotlib version.

The commands are read from the README's table, so the README cannot drift from the data
either. They run in this process: a benchmark started as a script puts the source tree's
seamfit first on its path, which has no compiled core where seamfit is installed (CI).
"""
from __future__ import annotations

import importlib
import re
import shlex

import pytest
from common import BENCHMARKS, REPO  # common imports the installed seamfit, with its core, first

DOCS = REPO / "docs"
README = DOCS / "results" / "data" / "README.md"
# `python tests/benchmarks/NAME.py report ...` (or ncu-report) in the README's backquotes
COMMAND = re.compile(r"`python (tests/benchmarks/\w+\.py (?:report|ncu-report) [^`]+)`")
PICTURE = re.compile(r"!\[[^]]*\]\((img/[^)]+)\)")
# Pictures only a run draws: the data keeps no drapes to draw them from.
DRAWN_BY_THE_RUN = {"img/drapes.png"}


def _commands() -> list[list[str]]:
    return [shlex.split(c) for c in COMMAND.findall(README.read_text())]


def _first_difference(want: str, got: str) -> str:
    a, b = want.splitlines(), got.splitlines()
    i = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))

    def line(lines):
        return repr(lines[i]) if i < len(lines) else "(end of page)"
    return f"first difference at line {i + 1}:\n  committed:   {line(a)}\n  regenerated: {line(b)}"


@pytest.mark.parametrize("command", _commands(), ids=lambda c: f"{c[0].rsplit('/', 1)[1]} {c[1]}")
def test_the_report_rewrites_its_committed_page(command, tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)  # the README's paths are relative to the repository root
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    bench = importlib.import_module(command[0].rsplit("/", 1)[1].removesuffix(".py"))
    (tmp_path / "img").mkdir()
    assert bench.main(command[1:] + ["--docs", str(tmp_path)]) in (0, None)
    pages = sorted(tmp_path.glob("*.md"))
    assert pages, f"`{' '.join(command)}` wrote no page"
    # the pages, and the merged data a report keeps beside them (bench_adjoint_gpu.py)
    for page in pages + sorted(tmp_path.glob("results/data/*.json")):
        name = page.relative_to(tmp_path)
        got, want = page.read_bytes(), (DOCS / name).read_bytes()
        assert got == want, f"docs/{name} is not what `{' '.join(command)}` writes; " \
                            + _first_difference(want.decode(), got.decode())
    for page in pages:
        for picture in PICTURE.findall(page.read_text()):
            drawn = (tmp_path / picture).is_file() or picture in DRAWN_BY_THE_RUN and (DOCS / picture).is_file()
            assert drawn, f"docs/{page.name} shows {picture}, which `{' '.join(command)}` did not draw"
