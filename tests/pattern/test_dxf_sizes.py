"""Multi-size DXF: a file holding several sizes (ASTM's multi-size form, as grade-run's
nest.dxf) reads back as one pattern per size; ``seamfit convert`` and ``validate`` take
``--size``, and say which sizes there are when one pattern is needed and none is chosen."""
from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from seamfit import cli
from seamfit.errors import PatternError
from seamfit.pattern import load_pattern
from seamfit.pattern.dxf import read_dxf_file, write_dxf
from seamfit.pattern.dxf_sizes import one_size, read_dxf_sizes, write_size_run_dxf
from seamfit.pattern.io import read_pattern_file
from common import REPO, SHARED_DATA, file_sha256
from outlines import outline_gap, polyline_distance, scaled_pattern

DXF_DIR = SHARED_DATA / "dxf"
SOURCE = DXF_DIR / "modell_2.astm.dxf"            # three pieces, all named "Detail", with cut lines
LABELS = ["S", "M", "L"]
SCALES = [0.96, 1.0, 1.04]                         # stand-ins for graded sizes around the sample M


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A three-size file built from Valentina's single-size export."""
    base = read_dxf_file(SOURCE).pattern
    sizes = [base if f == 1.0 else scaled_pattern(base, f) for f in SCALES]
    path = tmp_path_factory.mktemp("sizes") / "tshirt.astm.dxf"
    write_size_run_dxf(path, sizes, LABELS, 1)
    return path, sizes


def test_each_size_reads_back_within_a_tenth_of_a_millimetre(run):
    path, sizes = run
    back = read_dxf_sizes(path)
    assert back.labels == LABELS and back.sample_size == "M" and back.flavor == "astm"
    for lab, src in zip(LABELS, sizes):
        got = back.patterns[lab]
        assert got.extra["size"] == lab
        assert [p.name for p in got.panels] == [p.name for p in src.panels]   # "Detail", "Detail 2", ...
        for a, b in zip(src.panels, got.panels):
            assert b.extra["size"] == lab
            # every point of each outline lies on the other (the reader adds points on long segments)
            worst = outline_gap(a.outline_cm, b.outline_cm)
            assert worst < 0.01, (lab, a.name, worst)
            assert len(b.corners) == len(a.corners) and len(b.edges) == len(a.edges)
            if a.extra.get("grain_line_cm"):
                np.testing.assert_allclose(b.extra["grain_line_cm"], a.extra["grain_line_cm"], atol=0.01)
            assert ("cut_line_cm" in b.extra["dxf"]) == ("cut_line_cm" in a.extra.get("dxf", {}))


def test_one_pattern_needs_a_size_and_the_error_lists_them(run):
    path, _ = run
    back = read_dxf_sizes(path)
    with pytest.raises(PatternError, match=r"3 sizes \(S, M, L; sample size M\); choose one with --size NAME"):
        one_size(back, None)
    with pytest.raises(PatternError, match=r"no size 'XL'; the file holds sizes S, M, L"):
        read_pattern_file(path, size="XL")
    pattern, fmt = read_pattern_file(path, size="L")
    assert fmt == "dxf-astm" and pattern.extra["size"] == "L" and len(pattern.panels) == 3
    # a single-size file: --size names no size in it
    single = read_dxf_sizes(DXF_DIR / "Keiko_skirt.astm.dxf")
    assert list(single.patterns) == [None]
    with pytest.raises(PatternError, match="names no size"):
        one_size(single, "M")


def test_a_piece_without_its_size_in_a_multi_size_file_is_named(tmp_path):
    base = read_dxf_file(DXF_DIR / "Keiko_skirt.astm.dxf").pattern
    two = copy.deepcopy(base)
    big = scaled_pattern(base, 1.05)
    two.panels[0].extra["size"] = "38"
    two.panels[1].extra.pop("size", None)
    big.panels[0].extra["size"] = big.panels[1].extra["size"] = "40"
    for p in big.panels:
        p.name += " L"
    two.panels += big.panels
    write_dxf(two, tmp_path / "mixed.dxf", flavor="astm")
    with pytest.raises(PatternError, match=r"piece 'Detail 2' has no Size text.* 2 sizes \(38, 40\)"):
        read_dxf_sizes(tmp_path / "mixed.dxf")


def test_validate_checks_every_size_or_the_one_chosen(run, capsys):
    path, _ = run
    assert cli.main(["validate", str(path)]) == 0
    out = capsys.readouterr().out
    assert [line.split(", size ")[1] for line in out.splitlines() if ", size " in line] == LABELS
    assert out.count("\nOK") == 3
    assert cli.main(["validate", str(path), "--size", "S"]) == 0
    assert ", size S" in capsys.readouterr().out
    assert cli.main(["validate", str(path), "--size", "XL"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("no size 'XL'; the file holds sizes S, M, L") and "\n" not in err


def test_convert_picks_a_size_nests_them_all_or_keeps_them_all(run, tmp_path, capsys):
    path, sizes = run
    before = file_sha256(path)
    out = tmp_path / "one.json"
    assert cli.main(["convert", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "a multi-size DXF holding 3 sizes (S, M, L; sample size M); choose one with --size NAME" in err
    assert "\n" not in err and not out.exists()
    assert cli.main(["convert", str(path), "--size", "L", "--out", str(out), "-q"]) == 0
    got = load_pattern(out)
    for a, b in zip(sizes[2].panels, got.panels):
        assert polyline_distance(a.outline_cm, b.outline_cm).max() < 0.01
    # every size nested in one SVG, the sample size first (black)
    svg = tmp_path / "nest.svg"
    assert cli.main(["convert", str(path), "--out", str(svg), "-q"]) == 0
    groups = [g for g in ET.parse(svg).getroot().iter() if g.get("class") == "pattern"]
    assert sorted(g.get("data-label") for g in groups) == sorted(LABELS)
    assert next(g for g in groups if g.get("id") == "pattern-0").get("data-label") == "M"
    # every size again in one DXF-ASTM file
    again = tmp_path / "again.astm.dxf"
    assert cli.main(["convert", str(path), "--out", str(again), "-q"]) == 0
    back = read_dxf_sizes(again)
    assert back.labels == LABELS and back.sample_size == "M"
    for lab, src in zip(LABELS, sizes):
        for a, b in zip(src.panels, back.patterns[lab].panels):
            assert polyline_distance(a.outline_cm, b.outline_cm).max() < 0.01
    assert cli.main(["convert", str(path), "--out", str(tmp_path / "x.aama.dxf")]) == 2
    assert "choose one size with --size NAME (S, M, L)" in capsys.readouterr().err
    assert file_sha256(path) == before, "inputs are never modified"


def test_size_on_a_file_without_sizes_is_an_error(tmp_path, capsys):
    pattern = REPO / "sample_files/patterns/gc_pencil_skirt/size06/pattern.json"
    assert cli.main(["convert", str(pattern), "--size", "M", "--out", str(tmp_path / "x.svg")]) == 2
    assert "--size 'M' applies to a multi-size DXF file" in capsys.readouterr().err
    assert not (tmp_path / "x.svg").exists()


def test_grading_a_multi_size_file_says_how_to_pick_a_size(run, tmp_path, capsys):
    path, _ = run
    bodies = DXF_DIR.parent / "bodies"
    code = cli.main(["grade", str(path), "--base-body", str(bodies / "women_size06.obj"),
                     "--target-body", str(bodies / "women_size10.obj"), "--out", str(tmp_path / "g"), "-q"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "3 sizes (S, M, L" in err
    assert f"seamfit convert {path.name} --size NAME --out NAME.json" in err and not (tmp_path / "g").exists()
