"""Notches compared across a seam: on the shared patterns, notched as a pattern maker
notches them (at the same arc length on both sides of each stitch), validation finds
nothing, in sewpat-1 and read back from DXF; one notch moved 3 cm is a warning naming the
stitch and the notch, and the seam-matching proposals say so too."""
from __future__ import annotations

import copy

import ezdxf
import numpy as np
import pytest

from seamfit import cli
from seamfit.pattern import load_pattern, validate_pattern
from seamfit.pattern.dxf import read_dxf_file
from seamfit.pattern.model import range_indices
from seamfit.pattern.notches import NOTCH_MATCH_CM, notch_misses, side_notches
from seamfit.pattern.seams import propose_stitches
from common import SHARED_DATA

PATTERNS = SHARED_DATA / "patterns"
SHARED = sorted(PATTERNS.glob("*/size06/pattern.json"))
OUT_OF_STEP = "notches out of step"


def _arc(panel, side_range):
    o = panel.outline_cm
    idx = range_indices(side_range, len(o))
    return idx, np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(o[idx], axis=0), axis=1))])


def _add_notch(panel, vertex):
    notches = panel.extra.setdefault("notches", [])
    panel.landmarks[f"notch_{len(notches)}"] = int(vertex)
    notches.append({"vertex": int(vertex), "type": "slit", "depth_cm": 0.6})


def _notched(pattern):
    """A notch 40 % along side a of every stitch, and its partner on side b at the same arc
    length from where the sides meet (b's end: the stitches are 'reversed'; scaled to b's
    length where b is gathered)."""
    p = copy.deepcopy(pattern)
    panels = {q.name: q for q in p.panels}
    for s in p.stitches:
        pa, pb = panels[s.a.panel], panels[s.b.panel]
        ia, ca = _arc(pa, s.a.range)
        ib, cb = _arc(pb, s.b.range)
        if len(ia) < 3 or len(ib) < 3:
            continue
        j = int(np.argmin(np.abs(ca - 0.4 * ca[-1])))
        along = ca[j] * (cb[-1] / ca[-1] if s.gathered else 1.0)
        target = cb[-1] - along if s.orientation == "reversed" else along
        _add_notch(pa, ia[j])
        _add_notch(pb, ib[int(np.argmin(np.abs(cb - target)))])
    return p


def _moved(pattern, stitch, by_cm):
    """The notch on side b of ``stitch`` moved ``by_cm`` along its side."""
    p = copy.deepcopy(pattern)
    s = p.stitches[stitch]
    panel = next(q for q in p.panels if q.name == s.b.panel)
    idx, cum = _arc(panel, s.b.range)
    (name, at), = side_notches(panel, s.b.range)[0]
    k = int(name.split("_")[1])
    j = int(np.argmin(np.abs(cum - (at + by_cm))))
    panel.extra["notches"][k]["vertex"] = int(idx[j])
    panel.landmarks[name] = int(idx[j])
    return p, s.b.panel, name


@pytest.mark.parametrize("path", SHARED, ids=[p.parent.parent.name for p in SHARED])
def test_shared_patterns_notched_on_both_sides_pass(path):
    p = _notched(load_pattern(path))
    assert sum(len(q.extra.get("notches", [])) for q in p.panels) >= len(p.stitches)
    rep = validate_pattern(p)
    assert not rep.errors and not [w for w in rep.warnings if OUT_OF_STEP in w]


def test_a_notch_out_of_step_is_a_warning_naming_stitch_and_notch():
    base = _notched(load_pattern(PATTERNS / "gc_pencil_skirt/size06/pattern.json"))
    k = next(i for i, s in enumerate(base.stitches) if not s.gathered and s.a.panel != s.b.panel)
    moved, panel, name = _moved(base, k, 3.0)
    warns = [w for w in validate_pattern(moved).warnings if OUT_OF_STEP in w]
    assert len(warns) == 2                                   # the moved notch and its lost partner
    assert all(f"stitch {k} (" in w for w in warns)
    assert any(f"{name} of panel {panel!r} (side b)" in w and f"no notch within {NOTCH_MATCH_CM:g} cm" in w
               for w in warns)
    # within the tolerance it still lines up
    near, _, _ = _moved(base, k, 0.4 * NOTCH_MATCH_CM)
    assert not [w for w in validate_pattern(near).warnings if OUT_OF_STEP in w]


def test_notches_compared_through_dxf_and_the_validate_command(tmp_path, capsys):
    base = _notched(load_pattern(PATTERNS / "fs_pencil_skirt/size06/pattern.json"))
    k = next(i for i, s in enumerate(base.stitches) if s.a.panel != s.b.panel)
    moved, panel, name = _moved(base, k, 3.0)
    for tag, pat in (("good", base), ("moved", moved)):
        src = tmp_path / f"{tag}.json"
        from seamfit.pattern import save_pattern
        save_pattern(pat, src)
        dxf = tmp_path / f"{tag}.astm.dxf"                    # with its seams sidecar beside it
        assert cli.main(["convert", str(src), "--out", str(dxf), "-q"]) == 0
        code = cli.main(["validate", str(dxf)])
        out = capsys.readouterr().out
        lines = [line for line in out.splitlines() if OUT_OF_STEP in line]
        assert code == 0 and out.rstrip().endswith("OK")     # a warning, not an error
        if tag == "good":
            assert lines == []
        else:
            assert len(lines) == 2 and all(line.startswith("warning: ") and f"stitch {k} (" in line for line in lines)
            assert any(f"{name} of panel {panel!r}" in line for line in lines)
    assert cli.main(["validate", str(tmp_path / "moved.astm.dxf"), "--strict", "-q"]) == 1


def _two_rectangles(tmp_path, notch_b_cm):
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 5                              # cm
    for name, x in (("A", 0.0), ("B", 40.0)):
        blk = doc.blocks.new(name)
        blk.add_lwpolyline([(x, 0), (x + 20, 0), (x + 20, 50), (x, 50)], close=True, dxfattribs={"layer": "1"})
        doc.modelspace().add_blockref(name, (0, 0))
    doc.blocks.get("A").add_line((20, 20), (19.5, 20), dxfattribs={"layer": "4"})
    doc.blocks.get("B").add_line((40, notch_b_cm), (40.5, notch_b_cm), dxfattribs={"layer": "4"})
    path = tmp_path / f"two_{notch_b_cm:g}.dxf"
    doc.saveas(path)
    return path


def test_proposals_name_the_notches_that_do_not_line_up(tmp_path, capsys):
    lined = read_dxf_file(_two_rectangles(tmp_path, 20.0)).pattern
    best = propose_stitches(lined)[0]
    assert "line up" in best["why"] and "notch_warnings" not in best
    path = _two_rectangles(tmp_path, 24.0)                    # B's notch 4 cm higher than A's
    off = read_dxf_file(path).pattern
    paired = [s for s in propose_stitches(off) if {s["a"]["panel"], s["b"]["panel"]} == {"A", "B"}
              and "notch_warnings" in s]
    assert paired and any("notch_0 of panel 'A'" in w and "20.00 cm along the seam" in w
                          for s in paired for w in s["notch_warnings"])
    a = next(q for q in off.panels if q.name == "A")
    b = next(q for q in off.panels if q.name == "B")
    ra = (a.landmarks["corner_1"], a.landmarks["corner_2"])  # A's right side, upwards
    rb = (b.landmarks["corner_3"], b.landmarks["corner_0"])  # B's left side, downwards
    assert [m.notch for m in notch_misses(a, ra, b, rb)] == ["notch_0", "notch_0"]
    assert cli.main(["convert", str(path), "--propose-seams", str(tmp_path / "s.seams.json")]) == 0
    err = capsys.readouterr().err
    assert "warning: proposed stitch" in err and "(A / B): notch_0 of panel 'A'" in err


@pytest.mark.parametrize("notches", [5, "abc", {"vertex": 3},
                                     [None, {"vertex": 10 ** 9}, {"vertex": "x"}, {"vertex": True}]])
def test_malformed_notch_lists_are_not_compared(notches):
    p = load_pattern(PATTERNS / "gc_pencil_skirt/size06/pattern.json")
    p.panels[0].extra["notches"] = notches
    rep = validate_pattern(p)                                # a report, never an exception
    assert not [w for w in rep.warnings if OUT_OF_STEP in w]
