"""Grading accuracy against ground truth: landmark distances after a rigid alignment per
panel, with landmarks matched by name, or by outline order where GarmentCode's positional
ids shift because the drafting rules dropped a feature."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import baseline_errors, landmark_errors, load_pattern
from seamfit.pattern.compare import match_in_order, rigid_fit
from seamfit.pattern.model import range_indices
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
GARMENTS = ["gc_pencil_skirt", "gc_circle_skirt", "fs_bodice"]


@pytest.fixture(scope="module")
def samples():
    return {(g, s): load_pattern(PATTERNS / g / s / "pattern.json")
            for g in GARMENTS for s in ("size06", "size10")} | {
        ("gc_pencil_skirt", "apple"): load_pattern(PATTERNS / "gc_pencil_skirt/apple/pattern.json")}


def _distinct_landmark_vertices(panel) -> int:
    return len(set(panel.landmarks.values()))


@pytest.mark.parametrize("garment", GARMENTS)
def test_identical_patterns_have_zero_error(samples, garment):
    base = samples[(garment, "size06")]
    rep = landmark_errors(base, copy.deepcopy(base))
    assert rep.max_cm < 1e-9 and rep.mean_cm < 1e-9
    assert set(rep.panels) == {p.name for p in base.panels}
    assert rep.only_in_result == [] and rep.only_in_truth == [] and rep.notes == []
    for p in base.panels:
        pe = rep.panels[p.name]
        assert pe.matching == "name"
        assert set(pe.distances_cm) == set(p.landmarks)
        assert pe.n_points == _distinct_landmark_vertices(p)
        assert pe.perimeter_diff_cm == 0.0 and pe.area_diff_cm2 == 0.0
        assert set(pe.corners) == {n for n, i in p.landmarks.items() if i in set(p.corners)}


@pytest.mark.parametrize("garment", GARMENTS)
def test_rigidly_moved_panels_have_zero_error(samples, garment):
    base = samples[(garment, "size06")]
    moved = copy.deepcopy(base)
    for k, p in enumerate(moved.panels):
        a = math.radians(10.0 + 25.0 * k)
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        p.outline_cm = p.outline_cm @ rot.T + [40.0 * k - 13.0, 7.5]
    rep = landmark_errors(moved, base)
    assert rep.max_cm < 1e-9
    for k, p in enumerate(base.panels):
        pe = rep.panels[p.name]
        # the alignment undoes the move: result -> truth turns back by the applied angle
        assert pe.rotation_deg == pytest.approx(-(10.0 + 25.0 * k), abs=1e-9)
        assert abs(pe.perimeter_diff_cm) < 1e-9 and abs(pe.area_diff_pct) < 1e-9


@pytest.mark.parametrize("garment", GARMENTS)
def test_size06_against_size10_gives_plausible_errors(samples, garment):
    base, truth = samples[(garment, "size06")], samples[(garment, "size10")]
    rep = baseline_errors(base, truth)
    assert rep.label and "baseline" in rep.label
    # two sizes apart: landmarks move by millimetres to a few centimetres, never zero
    assert 0.2 < rep.max_cm < 10.0
    assert 0.0 < rep.mean_cm <= rep.max_cm
    assert rep.n_points == sum(pe.n_points for pe in rep.panels.values())
    assert rep.worst is not None and rep.panels[rep.worst[0]].distances_cm[rep.worst[1]] == rep.max_cm
    for p in base.panels:
        pe = rep.panels[p.name]
        assert pe.matching == "name"
        assert set(pe.distances_cm) == set(p.landmarks) & set(truth.panel(p.name).landmarks)
        assert pe.max_cm == max(pe.distances_cm.values())
        # the larger size is larger
        assert pe.perimeter_diff_cm < 0 and pe.area_diff_cm2 < 0
        if pe.corners:
            assert pe.corner_max_cm == max(pe.distances_cm[c] for c in pe.corners) <= pe.max_cm
    # the alignment is the least-squares rigid one: no other rotation/translation does better
    p = base.panels[0]
    t = truth.panel(p.name)
    names = sorted(set(p.landmarks) & set(t.landmarks))
    src = p.outline_cm[[p.landmarks[n] for n in names]]
    dst = t.outline_cm[[t.landmarks[n] for n in names]]
    pe = rep.panels[p.name]

    def sse(angle_deg, tx, ty):
        a = math.radians(angle_deg)
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        return float(np.sum((src @ rot.T + [tx, ty] - dst) ** 2))

    best = sse(pe.rotation_deg, *pe.translation_cm)
    for d in ([0.2, 0, 0], [-0.2, 0, 0], [0, 0.1, 0], [0, 0, -0.1]):
        assert sse(pe.rotation_deg + d[0], pe.translation_cm[0] + d[1], pe.translation_cm[1] + d[2]) > best


def test_changed_topology_matches_positional_ids_by_order(samples):
    """GarmentCode drops the pencil skirt's front darts for the apple body and renumbers
    the remaining vertex ids; the matching must skip exactly the dart vertices."""
    base, truth = samples[("gc_pencil_skirt", "size06")], samples[("gc_pencil_skirt", "apple")]
    rep = landmark_errors(base, truth)
    front = base.panel("skirt_front")
    # dart vertices of the base front: the ends of its dart stitches (one panel, both sides)
    dart_idx = set()
    for s in base.stitches:
        if s.a.panel == s.b.panel == "skirt_front":
            for side in (s.a, s.b):
                dart_idx.update(range_indices(side.range, front.n_vertices)[[0, -1]].tolist())
    darts = {n for n, i in front.landmarks.items() if i in dart_idx}
    assert len(darts) == 6
    pe = rep.panels["skirt_front"]
    assert pe.matching == "order"
    assert set(pe.pairs) == set(front.landmarks) - darts
    assert sorted(pe.pairs.values()) == sorted(truth.panel("skirt_front").landmarks)
    # order kept, and corners only meet corners
    t = truth.panel("skirt_front")
    order_r = [front.landmarks[a] for a in pe.pairs]
    order_t = [t.landmarks[b] for b in pe.pairs.values()]
    assert order_r == sorted(order_r) and order_t == sorted(order_t)
    assert all((front.landmarks[a] in front.corners) == (t.landmarks[b] in t.corners) for a, b in pe.pairs.items())
    assert any("skirt_front" in n and "matched in outline order" in n for n in rep.notes)
    # panels whose ids did not change are still matched by name
    assert rep.panels["skirt_back"].matching == "name"
    # matching the shifted ids by name would pair different points and err far more
    naive = {n: i for n, i in truth.panel("skirt_front").landmarks.items()}
    common = sorted(set(naive) & set(front.landmarks))
    src = front.outline_cm[[front.landmarks[n] for n in common]]
    dst = t.outline_cm[[naive[n] for n in common]]
    a, tr = rigid_fit(src, dst)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    naive_max = float(np.linalg.norm(src @ rot.T + tr - dst, axis=1).max())
    assert naive_max > 2 * pe.max_cm


@pytest.mark.parametrize("limit", [0, 10 ** 6], ids=["dynamic-programme", "exhaustive"])
def test_match_in_order_recovers_a_subsequence(limit):
    rng = np.random.default_rng(11)
    s = np.sort(rng.uniform(0, 2 * np.pi, 14))
    long_pts = np.stack([30 * np.cos(s), 18 * np.sin(s)], axis=1)
    keep = [0, 1, 2, 6, 7, 8, 9, 11, 12, 13]                   # drop a run of three and one more
    a = math.radians(8.0)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    short_pts = long_pts[keep] @ rot.T + [4.0, -2.0] + rng.normal(scale=0.05, size=(len(keep), 2))
    assert match_in_order(long_pts, short_pts, exhaustive_limit=limit) == keep


def test_one_common_landmark_and_no_common_panel(samples):
    base = samples[("gc_circle_skirt", "size06")]
    truth = copy.deepcopy(samples[("gc_circle_skirt", "size10")])
    p = truth.panel("wb_back")
    p.landmarks = {"gc_v0": p.landmarks["gc_v0"], "other": p.landmarks["gc_v1"]}
    rep = landmark_errors(base, truth)
    pe = rep.panels["wb_back"]
    assert list(pe.distances_cm) == ["gc_v0"] and pe.max_cm == 0.0
    assert any("translation only" in n for n in pe.notes)
    truth.panel("wb_back").landmarks = {"elsewhere": 0}
    rep = landmark_errors(base, truth)
    assert "wb_back" not in rep.panels
    assert any("'wb_back'" in n and "no landmark in common" in n for n in rep.notes)
    renamed = copy.deepcopy(base)
    for k, q in enumerate(renamed.panels):
        q.name = f"piece{k}"
    with pytest.raises(PatternError, match="no panel name in common"):
        landmark_errors(renamed, base)
    partial = copy.deepcopy(base)
    partial.panels[0].name = "extra"
    rep = landmark_errors(partial, base)
    assert rep.only_in_result == ["extra"] and rep.only_in_truth == [base.panels[0].name]


def test_report_serialises(samples):
    rep = landmark_errors(samples[("fs_bodice", "size06")], samples[("fs_bodice", "size10")])
    d = rep.to_dict()
    assert d["max_cm"] == rep.max_cm and set(d["panels"]) == set(rep.panels)
    table = rep.table().splitlines()
    assert table[0].split()[:2] == ["panel", "match"] and len(table) == len(rep.panels) + 2
    assert table[-1].startswith("all") and f"{rep.max_cm:.2f}" in table[-1]


def _scaled(pattern, factor, angle_deg=0.0, shift=(0.0, 0.0)):
    """Each panel scaled about its landmarks' centroid, then turned and moved rigidly."""
    out = copy.deepcopy(pattern)
    a = math.radians(angle_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    for p in out.panels:
        o = np.asarray(p.outline_cm, float)
        c = o[sorted(set(p.landmarks.values()))].mean(axis=0)
        p.outline_cm = (c + factor * (o - c)) @ rot.T + np.asarray(shift)
    return out


@pytest.mark.parametrize("garment", GARMENTS)
def test_change_captured_is_the_fraction_of_the_drafted_change(samples, garment):
    from seamfit.pattern import change_captured
    base = samples[(garment, "size06")]
    truth = _scaled(base, 1.10, angle_deg=7.0, shift=(3.0, -2.0))
    assert change_captured(base, base, truth) == pytest.approx(0.0, abs=1e-9)
    assert change_captured(truth, base, truth) == pytest.approx(1.0, abs=1e-9)
    # a result that grew 4 % where the draft grew 10 % made 0.4 of the change, wherever it lies
    assert change_captured(_scaled(base, 1.04, angle_deg=-20.0, shift=(50.0, 9.0)), base, truth) == \
        pytest.approx(0.4, abs=1e-9)
    assert change_captured(base, base, copy.deepcopy(base)) is None   # nothing to capture
    # only lengths drafted longer (v, along the grain): a result that grew only in width
    # captures none of it (to within what the rigid fit onto a stretched panel turns it)
    along = copy.deepcopy(base)
    wide = copy.deepcopy(base)
    for pa, pw in zip(along.panels, wide.panels):
        o = np.asarray(pa.outline_cm, float)
        c = o[sorted(set(pa.landmarks.values()))].mean(axis=0)
        pa.outline_cm = c + (o - c) * [1.0, 1.1]
        pw.outline_cm = c + (o - c) * [1.1, 1.0]
    assert change_captured(wide, base, along, axis=1) == pytest.approx(0.0, abs=0.01)
    assert change_captured(along, base, along, axis=1) == pytest.approx(1.0, abs=1e-9)
