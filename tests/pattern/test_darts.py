"""Truing straight darts before the refit (seamfit.pattern.darts): legs bent unequally by
the search come out of the refit as equal straight lines, and a dart already true is
left alone."""
from __future__ import annotations


import numpy as np

from seamfit.pattern import load_pattern
from seamfit.pattern.checks import output_checks
from seamfit.pattern.darts import dart_stitches, true_darts
from seamfit.pattern.refit import refit_pattern
from common import SAMPLES

SKIRT = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"


def _outlines(p):
    return {q.name: np.array(q.outline_cm, dtype=float) for q in p.panels}


def test_the_pencil_skirt_darts_are_found_with_their_tips():
    base = load_pattern(SKIRT)
    darts = dart_stitches(base)
    assert len(darts) == 6
    for d in darts:
        o = base.panel(d["panel"]).outline_cm
        a, b = d["base_lengths"]
        assert abs(a - b) < 0.01                       # the draft's legs are equal
        for leg in d["legs"]:
            assert leg[0] == d["tip"]
            assert np.isclose(np.linalg.norm(o[leg[-1]] - o[d["tip"]]), a, atol=0.01)


def test_a_true_dart_is_left_alone():
    base = load_pattern(SKIRT)
    outlines = _outlines(base)
    before = {k: v.copy() for k, v in outlines.items()}
    moved = true_darts(base, outlines)
    assert max(moved.values()) < 1e-6
    for k in outlines:
        assert np.allclose(outlines[k], before[k], atol=1e-9)


def test_unequally_bent_legs_come_out_equal_after_the_refit():
    base = load_pattern(SKIRT)
    d = dart_stitches(base)[0]
    outlines = _outlines(base)
    o = outlines[d["panel"]]
    # bow one leg sideways by 3 mm at its middle (the refit straightens it to its chord)
    # and pull the other's open end in by 2 mm
    leg_a, leg_b = d["legs"]
    tip = o[d["tip"]].copy()
    chord = o[leg_a[-1]] - tip
    normal = np.array([-chord[1], chord[0]]) / np.linalg.norm(chord)
    t = np.linspace(0.0, 1.0, len(leg_a))
    o[leg_a] += 0.3 * np.sin(np.pi * t)[:, None] * normal
    lb = np.linalg.norm(o[leg_b[-1]] - tip)
    o[leg_b[1:]] = tip + (o[leg_b[1:]] - tip) * (1.0 - 0.2 / lb)

    stitch = d["stitch"]
    plain = output_checks(base, refit_pattern(base, {k: v.copy() for k, v in outlines.items()}).pattern)
    assert plain["stitches"][stitch]["seam_mismatch_mm"] > 1.0

    moved = true_darts(base, outlines)
    assert 0.5 < moved[d["panel"]] < 3.0
    fixed = refit_pattern(base, outlines)
    checks = output_checks(base, fixed.pattern)
    assert checks["stitches"][stitch]["seam_mismatch_mm"] < 0.1
    # the tip stays, and the panel's other darts and stitches are as good as before
    assert np.allclose(fixed.pattern.panel(d["panel"]).outline_cm[d["tip"]], tip)
    for k, s in enumerate(checks["stitches"]):
        if k != stitch:
            assert s["seam_mismatch_mm"] <= plain["stitches"][k]["seam_mismatch_mm"] + 0.5
