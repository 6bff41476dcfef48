"""Output checks of a graded pattern against its base: seams that no longer sew, panels
turned off grain, self-intersecting outlines, and the displacement measures, each named
by stitch or panel."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import load_pattern, output_checks, refit_pattern
from seamfit.pattern.checks import best_fit_similarity
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"


@pytest.fixture(scope="module")
def pencil():
    return load_pattern(PATTERNS / "gc_pencil_skirt/size06/pattern.json")


@pytest.fixture(scope="module")
def circle():
    return load_pattern(PATTERNS / "gc_circle_skirt/size06/pattern.json")


@pytest.fixture(scope="module")
def bodice():
    return load_pattern(PATTERNS / "fs_bodice/size06/pattern.json")


def _rotated(o: np.ndarray, deg: float) -> np.ndarray:
    a = math.radians(deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    c = o.mean(axis=0)
    return (o - c) @ rot.T + c


def _failing_stitches(rep) -> set[int]:
    return {s["index"] for s in rep["stitches"] if not s["ok"]}


@pytest.mark.parametrize("name", ["pencil", "circle", "bodice"])
def test_unchanged_pattern_passes(name, request):
    base = request.getfixturevalue(name)
    rep = output_checks(base, copy.deepcopy(base))
    assert rep["ok"] and rep["messages"] == []
    assert rep["max_displacement_mm"] == 0.0 and rep["max_displacement_aligned_mm"] < 1e-9
    assert rep["max_grain_rotation_deg"] < 1e-9
    assert rep["self_intersections"] == 0
    for s in rep["stitches"]:
        if s["gathered"]:
            assert s["seam_mismatch_mm"] < 1e-9 and s["base_ratio"] != pytest.approx(1.0, abs=1e-3)
        else:
            assert s["seam_mismatch_mm"] == pytest.approx(s["base_mismatch_mm"], abs=1e-12)
    assert len(rep["stitches"]) == len(base.stitches)


def test_uniform_scale_passes_and_keeps_designed_ease(bodice):
    """Scaling by 5 % grows the bodice's ~2.5 mm designed shoulder ease past 2 mm; in
    proportion to the seam it is no worse than the base, so it passes."""
    res = refit_pattern(bodice, {p.name: 1.05 * p.outline_cm for p in bodice.panels})
    rep = output_checks(bodice, res.pattern)
    assert rep["ok"], rep["messages"]
    eased = [s for s in rep["stitches"] if s["base_mismatch_mm"] > 2.0]
    assert eased and all(s["seam_mismatch_mm"] > 2.0 and s["ok"] for s in eased)
    # the designed ease grew with the seam: nothing is in excess of it
    assert rep["max_seam_mismatch_mm"] > 2.0 and rep["max_seam_excess_mm"] < 1e-9
    for p in rep["panels"].values():
        assert abs(p["grain_rotation_deg"]) < 1e-6
        assert p["scale"] == pytest.approx(1.05, abs=1e-6)
        assert p["area_cm2"] == pytest.approx(1.05 ** 2 * p["area_base_cm2"], rel=1e-6)
    # plain displacement counts the whole scaling about the origin; aligned only shape change
    assert rep["displacement_alignment"] == "none"
    assert 0 < rep["max_displacement_aligned_mm"] < rep["max_displacement_mm"]
    o = bodice.panels[0].outline_cm
    assert rep["panels"][bodice.panels[0].name]["max_displacement_mm"] == pytest.approx(
        10 * 0.05 * np.linalg.norm(o, axis=1).max(), rel=1e-3)


def test_panel_rotated_two_degrees_is_flagged(pencil):
    result = copy.deepcopy(pencil)
    panel = result.panel("skirt_back")
    panel.outline_cm = _rotated(panel.outline_cm, 2.0)
    rep = output_checks(pencil, result)
    assert not rep["ok"]
    assert rep["panels"]["skirt_back"]["grain_rotation_deg"] == pytest.approx(2.0, abs=1e-9)
    assert not rep["panels"]["skirt_back"]["ok"]
    assert all(p["ok"] for n, p in rep["panels"].items() if n != "skirt_back")
    grain = [m for m in rep["messages"] if "grain" in m]
    assert len(grain) == 1 and "panel 'skirt_back'" in grain[0] and "+2.00 deg" in grain[0]
    # a rigid turn changes no seam length and no shape
    assert _failing_stitches(rep) == set()
    assert rep["panels"]["skirt_back"]["max_displacement_aligned_mm"] < 1e-9


def test_small_rotation_passes(pencil):
    result = copy.deepcopy(pencil)
    panel = result.panel("skirt_back")
    panel.outline_cm = _rotated(panel.outline_cm, -0.5)
    rep = output_checks(pencil, result)
    assert rep["ok"], rep["messages"]
    assert rep["panels"]["skirt_back"]["grain_rotation_deg"] == pytest.approx(-0.5, abs=1e-9)


def test_grain_rotation_ignores_scale_and_translation():
    rng = np.random.default_rng(3)
    src = rng.normal(size=(40, 2)) * [30.0, 10.0]
    a = math.radians(0.7)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    dst = 1.1 * src @ rot.T + [5.0, -3.0]
    angle, s, t = best_fit_similarity(src, dst)
    assert math.degrees(angle) == pytest.approx(0.7, abs=1e-9)
    assert s == pytest.approx(1.1) and t == pytest.approx([5.0, -3.0])


def test_stitch_side_lengthened_by_3mm_is_flagged(pencil):
    """Stitch 6 sews the lower side seam skirt_front [224, 0] (ending at the hem corner,
    vertex 0) to skirt_back [0, 32]; moving the hem corner 3 mm down the seam lengthens
    side a by 3 mm and touches no other stitch (the hem is not sewn)."""
    s6 = pencil.stitches[6]
    assert (s6.a.panel, tuple(s6.a.range), s6.gathered) == ("skirt_front", (224, 0), False)
    result = copy.deepcopy(pencil)
    o = result.panel("skirt_front").outline_cm
    direction = (o[0] - o[224]) / np.linalg.norm(o[0] - o[224])
    o[0] = o[0] + 0.3 * direction
    rep = output_checks(pencil, result)
    assert not rep["ok"]
    assert _failing_stitches(rep) == {6}
    entry = rep["stitches"][6]
    assert entry["seam_mismatch_mm"] == pytest.approx(3.0 + entry["base_mismatch_mm"], abs=0.01)
    assert rep["max_seam_excess_mm"] == pytest.approx(entry["excess_mm"]) and entry["excess_mm"] > 2.9
    msg = [m for m in rep["messages"] if "stitch 6" in m]
    assert len(msg) == 1 and "skirt_front [224, 0]" in msg[0] and "skirt_back [0, 32]" in msg[0]
    assert "differ by 3.00 mm" in msg[0]
    # 1.5 mm is within the 2 mm tolerance
    o[0] = pencil.panel("skirt_front").outline_cm[0] + 0.15 * direction
    assert output_checks(pencil, result)["ok"]


def test_gathered_stitch_is_checked_against_the_base_ratio(circle):
    """Stitch 4 gathers skirt_front [246, 0] (34.3 cm) into wb_front [0, 37] (36.3 cm).
    Lengthening the waistband side by 4 mm breaks the base's gathering ratio by 4 mm."""
    s4 = circle.stitches[4]
    assert s4.gathered and (s4.a.panel, tuple(s4.a.range)) == ("wb_front", (0, 37))
    result = copy.deepcopy(circle)
    o = result.panel("wb_front").outline_cm
    o[0] = o[0] + 0.4 * (o[0] - o[1]) / np.linalg.norm(o[0] - o[1])
    rep = output_checks(circle, result)
    assert _failing_stitches(rep) == {4}
    entry = rep["stitches"][4]
    assert entry["base_ratio"] == pytest.approx(entry["base_length_a_cm"] / entry["base_length_b_cm"])
    assert entry["seam_mismatch_mm"] == pytest.approx(4.0, abs=0.01)
    assert any("stitch 4" in m and "gathering ratio" in m for m in rep["messages"])
    # scaling both sides together keeps the ratio: no mismatch
    scaled = refit_pattern(circle, {p.name: 1.04 * p.outline_cm for p in circle.panels}).pattern
    rep2 = output_checks(circle, scaled)
    assert rep2["stitches"][4]["seam_mismatch_mm"] < 0.01 and rep2["ok"]


def test_self_intersection_is_flagged(pencil):
    result = copy.deepcopy(pencil)
    panel = result.panel("wb_back")
    o = panel.outline_cm
    top = o[:, 1].max()
    k = int(np.argmin(np.abs(o[:, 0] - 16.0) + 100 * (o[:, 1] > 0.01)))   # a bottom-edge vertex
    o[k, 1] = top + 1.0                                                  # pushed through the top
    rep = output_checks(pencil, result)
    assert not rep["ok"]
    assert rep["panels"]["wb_back"]["self_intersections"]
    assert rep["self_intersections"] == len(rep["panels"]["wb_back"]["self_intersections"])
    msg = [m for m in rep["messages"] if "self-intersecting" in m]
    assert len(msg) == 1 and "panel 'wb_back'" in msg[0] and f"{k - 1}-{k}" in msg[0]


def test_translation_counts_only_in_plain_displacement(pencil):
    result = copy.deepcopy(pencil)
    result.panel("wb_front").outline_cm = result.panel("wb_front").outline_cm + [3.0, 4.0]
    rep = output_checks(pencil, result)
    assert rep["ok"]
    p = rep["panels"]["wb_front"]
    assert p["max_displacement_mm"] == pytest.approx(50.0)
    assert p["max_displacement_aligned_mm"] < 1e-9
    assert rep["max_displacement_mm"] == pytest.approx(50.0)


def test_inside_out_panel_is_flagged(pencil):
    result = copy.deepcopy(pencil)
    panel = result.panel("wb_front")
    panel.outline_cm = panel.outline_cm * [-1.0, 1.0]                    # mirrored: runs the other way
    rep = output_checks(pencil, result)
    assert not rep["panels"]["wb_front"]["orientation_ok"]
    assert any("panel 'wb_front'" in m and "inside out" in m for m in rep["messages"])


def test_patterns_that_do_not_correspond_raise(pencil, circle):
    renamed = copy.deepcopy(pencil)
    renamed.panels[0].name = "yoke"
    with pytest.raises(PatternError, match=r"panels \['yoke'.* do not match the base"):
        output_checks(pencil, renamed)
    # same panel names (both skirts have them), different garment
    with pytest.raises(PatternError, match="6 stitches, the base has 20"):
        output_checks(pencil, circle)
    result = copy.deepcopy(pencil)
    result.panel("wb_back").outline_cm = result.panel("wb_back").outline_cm[:-2]
    with pytest.raises(PatternError, match=r"panel 'wb_back': outline has 76 points, the base 78"):
        output_checks(pencil, result)
    result = copy.deepcopy(pencil)
    result.stitches.pop()
    with pytest.raises(PatternError, match="19 stitches, the base has 20"):
        output_checks(pencil, result)
