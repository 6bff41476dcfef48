"""The graded DXF form read back: a base DXF whose grade points carry '# n' rule numbers, with
its RUL table (as grade-run's graded.dxf / graded.rul), gives one pattern per size, through
the API and ``seamfit convert/validate --rul``; a bad rule table is a one-line error.
grade-run's own output is read back in tests/opt/test_grade_run.py."""
from __future__ import annotations


import numpy as np
import pytest

from seamfit import cli
from seamfit.errors import PatternError
from seamfit.pattern import load_pattern
from seamfit.pattern.dxf import read_dxf_file
from seamfit.pattern.dxf_graded import proportional_moves, read_graded_dxf
from seamfit.pattern.dxf_sizes import grade_points, read_dxf_sizes, write_graded_dxf
from common import SHARED_DATA, file_sha256
from outlines import anchor, outline_gap, scaled_pattern

DXF_DIR = SHARED_DATA / "dxf"
SOURCE = DXF_DIR / "modell_2.astm.dxf"            # three pieces with cut lines, notches, grain lines
LABELS = ["S", "M", "L"]
SCALES = [(0.96, 0.98), (1.0, 1.0), (1.05, 1.02)]  # (width, length) of each size against M


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = read_dxf_file(SOURCE).pattern
    sizes = [base if s == (1.0, 1.0) else scaled_pattern(base, s) for s in SCALES]
    folder = tmp_path_factory.mktemp("graded")
    write_graded_dxf(folder / "modell.dxf", folder / "modell.rul", sizes, LABELS, 1)
    return folder, sizes


def test_each_size_reads_back_with_its_grade_points_in_place(run):
    folder, sizes = run
    back = read_graded_dxf(folder / "modell.dxf", folder / "modell.rul")
    assert back.labels == LABELS and back.sample_size == "M" and back.flavor == "astm"
    base = sizes[1]
    for lab, src in zip(LABELS, sizes):
        got = back.patterns[lab]
        assert got.extra["size"] == lab and [p.name for p in got.panels] == [p.name for p in base.panels]
        for b, a, g in zip(base.panels, src.panels, got.panels):
            assert g.extra["size"] == lab
            assert not any(t["text"].startswith("#") for t in g.extra["dxf"].get("texts", []))
            # the RUL moves are in the top-centre frame: the size's points relative to the base's top-centre
            want = a.outline_cm - anchor(a.outline_cm) + anchor(b.outline_cm)
            gp = grade_points(b)
            assert np.abs(g.outline_cm[gp] - want[gp]).max() < 0.01, (lab, a.name)     # 0.1 mm
            # between grade points the points follow in proportion to arc length, which a curve scaled
            # more across than along does not quite do: measured up to 0.99 mm (size L, 'Detail')
            assert outline_gap(g.outline_cm, want) < 0.12
            assert g.corners == b.corners and len(g.edges) == len(b.edges)
            assert [n["vertex"] for n in g.extra.get("notches", [])] == [n["vertex"] for n in b.extra.get("notches", [])]
            # the sample size keeps its cut line; a graded size's is rebuilt from the allowances
            assert ("cut_line_cm" in g.extra["dxf"]) == (lab == "M")
            assert all("seam_allowance_cm" in e.extra for e in g.edges)


def test_proportional_moves_between_grade_points():
    square = np.array([[0, 0], [1, 0], [2, 0], [2, 2], [0, 2]], dtype=float)
    m = proportional_moves(square, [0, 2], np.array([[0.0, 0.0], [1.0, 0.0]]))
    np.testing.assert_allclose(m[:3, 0], [0.0, 0.5, 1.0])                 # along the edge 0 -> 2
    np.testing.assert_allclose(m[3:, 0], [1 - 2 / 6, 1 - 4 / 6])         # back round 2 -> 0 (6 cm)
    np.testing.assert_allclose(proportional_moves(square, [3], np.array([[1.0, 2.0]])), np.tile([1.0, 2.0], (5, 1)))


def test_convert_and_validate_take_the_rule_table(run, tmp_path, capsys):
    folder, sizes = run
    dxf, rul = folder / "modell.dxf", folder / "modell.rul"
    before = (file_sha256(dxf), file_sha256(rul))
    out = tmp_path / "L.json"
    assert cli.main(["convert", str(dxf), "--rul", str(rul), "--size", "L", "--out", str(out), "-q"]) == 0
    api = read_graded_dxf(dxf, rul).patterns["L"]
    for a, b in zip(api.panels, load_pattern(out).panels):
        np.testing.assert_allclose(b.outline_cm, a.outline_cm, atol=1e-9)
    nest = tmp_path / "all.astm.dxf"                                      # every size in the multi-size form
    assert cli.main(["convert", str(dxf), "--rul", str(rul), "--out", str(nest), "-q"]) == 0
    multi = read_dxf_sizes(nest)
    assert multi.labels == LABELS and multi.sample_size == "M"
    assert cli.main(["validate", str(dxf), "--rul", str(rul)]) == 0
    assert capsys.readouterr().out.count("\nOK") == 3
    assert cli.main(["convert", str(dxf), "--rul", str(rul), "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "a base DXF graded by modell.rul to 3 sizes (S, M, L; sample size M)" in err and "\n" not in err
    assert "seamfit convert modell.dxf --rul modell.rul --size NAME" in err and not (tmp_path / "x.json").exists()
    assert (file_sha256(dxf), file_sha256(rul)) == before, "inputs are never modified"


def _bad(folder, tmp_path, edit):
    rul = tmp_path / "bad.rul"
    rul.write_text(edit((folder / "modell.rul").read_text()))
    return rul


@pytest.mark.parametrize("edit, needle", [
    (lambda t: t.replace("RULE: DELTA 2\n", "RULE: DELTA 999\n"), "piece 'Detail': grade rule # 2 at"),
    (lambda t: t.replace("UNITS: METRIC", "UNITS: ENGLISH"), "UNITS ENGLISH but modell.dxf is in mm"),
    (lambda t: t.replace("SAMPLE SIZE: M", "SAMPLE SIZE: XL"), "SAMPLE SIZE 'XL' is not in the SIZE LIST (S M L)"),
    (lambda t: t.replace("RULE: DELTA 3\n", "RULE: DELTA 3\n1.0,2.0\n"), "rule 3 has more moves than"),
    (lambda t: t.replace(" 0.000,0.000", "", 1), "rule 1 has 2 moves, the SIZE LIST 3 sizes"),
    (lambda t: t.replace("RULE: DELTA 1", "RULE: INCREMENT 1"), "only 'RULE: DELTA <number>' rules are read"),
])
def test_a_bad_rule_table_is_a_one_line_error(run, tmp_path, capsys, edit, needle):
    folder, _ = run
    rul = _bad(folder, tmp_path, edit)
    out = tmp_path / "x.json"
    code = cli.main(["convert", str(folder / "modell.dxf"), "--rul", str(rul), "--size", "L", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and needle in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()


def test_a_rule_missing_from_the_table_names_piece_and_rule(run, tmp_path):
    folder, _ = run
    rul = _bad(folder, tmp_path, lambda t: t.replace("RULE: DELTA 2\n", "RULE: DELTA 999\n"))
    with pytest.raises(PatternError, match=r"modell.dxf: piece 'Detail': grade rule # 2 at .*: no rule 2 in bad.rul "
                                           r"\(its rules: 1, 3-\d+, 999\)"):
        read_graded_dxf(folder / "modell.dxf", rul)


def test_a_size_the_table_lacks_is_named(run, capsys):
    folder, _ = run
    code = cli.main(["validate", str(folder / "modell.dxf"), "--rul", str(folder / "modell.rul"), "--size", "XL"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.endswith("no size 'XL'; the file holds sizes S, M, L") and "\n" not in err


def test_rules_on_the_cut_line_go_to_the_seam_corner(run, tmp_path):
    """AAMA's boundary is the cut line: a rule number there grades the seam line's nearest
    edge end. modell_2's corner rules moved onto its mitred cut-line corners (through ezdxf)."""
    import ezdxf
    folder, sizes = run
    doc = ezdxf.readfile(folder / "modell.dxf")
    moved = 0
    for ref in doc.modelspace().query("INSERT"):
        blk = doc.blocks.get(ref.dxf.name)
        cut = np.array([p[:2] for e in blk if e.dxftype() == "LWPOLYLINE" and e.dxf.layer == "1"
                        for p in e.get_points("xy")])
        corners = np.array([(e.dxf.location.x, e.dxf.location.y) for e in blk if e.dxftype() == "POINT" and e.dxf.layer == "2"])
        for e in blk:
            if e.dxftype() == "TEXT" and e.dxf.text.startswith("# "):
                q = np.array((e.dxf.insert.x, e.dxf.insert.y))
                if len(corners) and np.linalg.norm(corners - q, axis=1).min() < 1e-6:
                    c = cut[np.argmin(np.linalg.norm(cut - q, axis=1))]
                    e.dxf.insert = (float(c[0]), float(c[1]))
                    moved += 1
    assert moved > 10
    doc.saveas(tmp_path / "on_cut.dxf")
    back = read_graded_dxf(tmp_path / "on_cut.dxf", folder / "modell.rul")
    assert sum(int(m.split(": ")[-1].split()[0]) for m in back.notes if "on the cut line" in m) == moved
    base = sizes[1]
    for lab, src in zip(LABELS, sizes):
        for b, a, g in zip(base.panels, src.panels, back.patterns[lab].panels):
            want = a.outline_cm - anchor(a.outline_cm) + anchor(b.outline_cm)
            # the rules were measured at the seam corners: mapped back there, each corner is in place
            assert np.abs(g.outline_cm[b.corners] - want[b.corners]).max() < 0.01, (lab, a.name)
