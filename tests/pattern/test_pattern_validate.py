"""Validation: every check fires on a deliberately broken copy of a sample pattern and its
message names the file, panel, stitch (index and kind) or vertex at fault."""
from __future__ import annotations

import copy
import re
import time

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import check_pattern, fix_pattern, load_pattern, save_pattern, validate_pattern
from seamfit.pattern.sewpat import pattern_to_dict
from seamfit.pattern.validate import find_self_intersections
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
PENCIL = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
BODICE = PATTERNS / "fs_bodice/size06/pattern.json"


@pytest.fixture(scope="module")
def pencil():
    return load_pattern(PENCIL)


@pytest.fixture
def skirt(pencil):
    return copy.deepcopy(pencil)


def _one(messages: list[str], *needles: str) -> str:
    hits = [m for m in messages if all(n in m for n in needles)]
    assert len(hits) == 1, (needles, messages)
    return hits[0]


@pytest.mark.parametrize("path", sorted(PATTERNS.glob("*/*/pattern.json"))
                         + sorted(PATTERNS.glob("*/*/native/*_specification.json")),
                         ids=lambda p: str(p.relative_to(PATTERNS)))
def test_samples_are_valid(path):
    rep = check_pattern(load_pattern(path))
    assert rep.ok and rep.errors == [] and rep.warnings == []


def test_open_outline(skirt):
    skirt.panels[1].outline_cm = skirt.panels[1].outline_cm[:2]
    rep = validate_pattern(skirt)
    assert not rep.ok
    m = _one(rep.errors, "open outline")
    assert m.startswith(f"{PENCIL}: panel 'wb_back': open outline: 2 point(s)")


def test_closing_duplicate_is_fixable_warning(skirt, pencil, tmp_path):
    panel = skirt.panels[2]
    n = panel.n_vertices
    panel.outline_cm = np.vstack([panel.outline_cm, panel.outline_cm[:1]])
    rep = validate_pattern(skirt)
    assert rep.ok, rep.errors
    m = _one(rep.warnings, "repeats vertex 0")
    assert f"panel 'wb_front': outline vertex {n} repeats vertex 0" in m and m in rep.fixable
    done = fix_pattern(skirt)
    assert len(done) == 1 and "wb_front" in done[0]
    rep = validate_pattern(skirt)
    assert rep.ok and rep.warnings == []
    out = save_pattern(skirt, tmp_path / "fixed.json")
    assert pattern_to_dict(load_pattern(out)) == pattern_to_dict(pencil)


def test_fix_remaps_indices_that_pointed_at_the_duplicate(skirt):
    panel = skirt.panels[0]                        # skirt_back, last edge runs to vertex 0
    n = panel.n_vertices
    panel.outline_cm = np.vstack([panel.outline_cm, panel.outline_cm[:1]])
    last = panel.edges[-1]
    last.end = n                                   # as a writer that closes outlines would do
    fix_pattern(skirt)
    assert panel.n_vertices == n and last.end == 0
    assert validate_pattern(skirt).ok


def test_self_intersection_names_segments(skirt):
    panel = skirt.panels[0]                        # skirt_back; 287..0 is the straight hem
    o = panel.outline_cm.copy()
    assert np.all(o[295:306, 1] == 0.0)
    # swap two hem samples and lift both 3 mm: segments 299-300 and 301-302 cross
    o[300], o[301] = o[301] + [0, 0.3], o[300] + [0, 0.3]
    panel.outline_cm = o
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "self-intersecting")
    assert m == (f"{PENCIL}: panel 'skirt_back': self-intersecting outline: 1 crossing(s), "
                 "segments 299-300 x 301-302")
    # and a far swap is found with all its crossings named by vertex pairs
    o = panel.outline_cm.copy()
    o[[100, 250]] = o[[250, 100]]
    panel.outline_cm = o
    m = _one(validate_pattern(skirt).errors, "self-intersecting")
    pairs = re.findall(r"(\d+)-(\d+) x (\d+)-(\d+)", m)
    assert pairs and all(int(b) == int(a) + 1 and int(d) == int(c) + 1 for a, b, c, d in pairs)


def test_self_intersection_check_agrees_with_brute_force():
    rng = np.random.default_rng(7)

    def brute(o):
        n = len(o)
        out = []

        def orient(p, q, r):
            return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

        def on(p, q, r):
            return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue
                a1, b1, a2, b2 = o[i], o[(i + 1) % n], o[j], o[(j + 1) % n]
                d = [orient(a1, b1, a2), orient(a1, b1, b2), orient(a2, b2, a1), orient(a2, b2, b1)]
                if (d[0] * d[1] < 0 and d[2] * d[3] < 0) or (d[0] == 0 and on(a1, b1, a2)) \
                        or (d[1] == 0 and on(a1, b1, b2)) or (d[2] == 0 and on(a2, b2, a1)) \
                        or (d[3] == 0 and on(a2, b2, b1)):
                    out.append((i, j))
        return out
    for trial in range(60):
        o = rng.random((int(rng.integers(4, 40)), 2)) * 30
        if trial % 3 == 0:                          # on a grid: touching and collinear cases
            o = np.round(o)
            o = o[np.linalg.norm(o - np.roll(o, -1, axis=0), axis=1) > 0]
            if len(o) < 4:
                continue
        assert find_self_intersections(o) == brute(o), trial


def test_self_intersection_check_is_fast():
    n = 5000
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = 50 + 5 * np.sin(7 * th)
    o = np.stack([r * np.cos(th), r * np.sin(th)], axis=1)
    o[[1000, 3000]] = o[[3000, 1000]]               # two long segments across the panel
    t = time.perf_counter()
    hits = find_self_intersections(o)
    elapsed = time.perf_counter() - t
    assert hits and all(i in (999, 1000, 2999, 3000) or j in (999, 1000, 2999, 3000) for i, j in hits)
    assert elapsed < 0.5, elapsed                   # ~15 ms measured; a quadratic check takes seconds


def test_zero_length_segment(skirt):
    panel = skirt.panels[3]
    panel.outline_cm = panel.outline_cm.copy()
    panel.outline_cm[11] = panel.outline_cm[10]
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "zero-length outline segment")
    assert "panel 'skirt_front'" in m and "vertices 10-11" in m


def test_stitch_range_out_of_bounds(skirt):
    k = 7
    s = skirt.stitches[k]
    n = skirt.panel(s.b.panel).n_vertices
    s.b.range = (s.b.range[0], n + 5)
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "out of bounds")
    assert m.startswith(f"{PENCIL}: stitch {k} ({s.kind}) side b (panel {s.b.panel!r}")
    assert f"vertex {n + 5} out of bounds (panel has {n} vertices" in m


def test_stitch_unknown_panel(skirt):
    skirt.stitches[3].a.panel = "sleeve"
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "unknown panel")
    assert m.startswith(f"{PENCIL}: stitch 3 ({skirt.stitches[3].kind}) side a (panel 'sleeve'")


def test_stitch_unknown_edge(skirt):
    skirt.stitches[0].a.edge = 99
    m = _one(validate_pattern(skirt).errors, "has no edge 99")
    assert "stitch 0 (dart_or_internal) side a" in m


def test_stitch_length_mismatch_needs_gathered(skirt):
    # the sample's gathered side seams differ by ~1 cm; unmarked, they break the tolerance
    gathered = [k for k, s in enumerate(skirt.stitches) if s.gathered]
    assert gathered
    for k in gathered:
        skirt.stitches[k].gathered = False
    rep = validate_pattern(skirt)
    msgs = [m for m in rep.errors if "side lengths differ" in m]
    assert len(msgs) == len(gathered)
    for k in gathered:
        m = _one(msgs, f"stitch {k} (seam)")
        assert "not marked gathered" in m and f"panel {skirt.stitches[k].a.panel!r}" in m
    # a looser tolerance accepts them
    assert validate_pattern(skirt, seam_tolerance_cm=1.5).ok


def test_stitch_length_mismatch_on_shortened_side(skirt):
    k = 6                                          # a straight 31.7 cm side seam
    s = skirt.stitches[k]
    assert not s.gathered
    n = skirt.panel(s.b.panel).n_vertices
    s.b.range = (s.b.range[0], (s.b.range[1] - 3) % n)
    m = _one(validate_pattern(skirt).errors, "side lengths differ")
    assert f"stitch {k} (seam)" in m and "more than 1.00 cm" in m


def test_dart_sides_overlap(skirt):
    s = skirt.stitches[2]                          # a back dart: two legs of one panel
    assert s.a.panel == s.b.panel
    s.b.range = (s.a.range[0], s.b.range[1])
    s.gathered = True                              # isolate the overlap check
    m = _one(validate_pattern(skirt).errors, "overlap")
    assert "stitch 2 (dart_or_internal)" in m and "panel 'skirt_back'" in m


def test_degenerate_edge(skirt):
    e = skirt.panels[0].edges[4]
    e.end = e.start
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "degenerate edge")
    assert f"panel 'skirt_back' edge 4 (line): degenerate edge: starts and ends at outline vertex {e.start}" in m


def test_non_finite_outline_curve_and_placement(skirt):
    skirt.panels[0].outline_cm = skirt.panels[0].outline_cm.copy()
    skirt.panels[0].outline_cm[42, 1] = np.nan
    skirt.panels[1].edges[0].p1 = (np.inf, 0.0)
    skirt.panels[2].placement.translation_m = np.array([0.0, np.nan, 1.0])
    e = next(e for e in skirt.panels[3].edges if e.kind == "quadratic")
    e.ctrl = [(np.nan, 1.0)]
    rep = validate_pattern(skirt)
    assert "outline vertex 42" in _one(rep.errors, "panel 'skirt_back'", "NaN")
    assert "edge 0 (line)" in _one(rep.errors, "panel 'wb_back'", "NaN")
    assert "placement translation" in _one(rep.errors, "panel 'wb_front'", "NaN")
    assert f"edge {e.id} (quadratic)" in _one(rep.errors, "panel 'skirt_front'", "NaN")


def test_arc_parameters_non_finite():
    p = load_pattern(PATTERNS / "gc_circle_skirt/size06/pattern.json")
    e = next(e for e in p.panels[1].edges if e.kind == "arc")
    e.arc = dict(e.arc, radius=float("inf"))
    m = _one(validate_pattern(p).errors, "arc parameter")
    assert f"panel {p.panels[1].name!r} edge {e.id} (arc)" in m


@pytest.mark.parametrize("factor, unit", [(10.0, "millimetres"), (0.01, "metres")])
def test_implausible_units(skirt, factor, unit):
    for panel in skirt.panels:
        panel.outline_cm = panel.outline_cm * factor
    rep = validate_pattern(skirt)
    m = _one(rep.errors, "implausible units")
    assert f"looks like {unit}" in m and "largest panel 'skirt_back'" in m


def test_orientation_mismatch(skirt):
    skirt.panels[3].orientation = "cw"
    m = _one(validate_pattern(skirt).errors, "orientation")
    assert "panel 'skirt_front': declared orientation 'cw' but the outline runs counter-clockwise" in m


def test_rotation_not_rigid(skirt):
    skirt.panels[0].placement.rotation = skirt.panels[0].placement.rotation * 1.1
    assert "panel 'skirt_back'" in _one(validate_pattern(skirt).errors, "not a rotation")


def test_index_out_of_outline(skirt):
    skirt.panels[1].landmarks["gc_v9"] = 10_000
    skirt.panels[1].corners.append(-1)
    rep = validate_pattern(skirt)
    assert "'gc_v9'=10000" in _one(rep.errors, "panel 'wb_back'", "landmark")
    assert "-1" in _one(rep.errors, "panel 'wb_back'", "corner vertex index")


def test_check_pattern_lists_every_error(skirt):
    skirt.stitches[3].a.panel = "sleeve"
    skirt.panels[0].edges[4].end = skirt.panels[0].edges[4].start
    with pytest.raises(PatternError) as info:
        check_pattern(skirt)
    text = str(info.value)
    assert text.startswith(f"{PENCIL}: invalid pattern, 2 error(s)")
    assert "unknown panel 'sleeve'" in text and "degenerate edge" in text


def test_fresh_pattern_messages_name_a_placeholder_file():
    p = copy.deepcopy(load_pattern(BODICE))
    p.source_file = None
    p.panels[0].outline_cm = p.panels[0].outline_cm[:1]
    assert validate_pattern(p).errors[0].startswith("<pattern>: panel 'front': open outline")
