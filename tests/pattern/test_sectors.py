"""Truing circle skirts (seamfit.pattern.sectors): a panel drafted as an annular sector is
found, comes out of truing as a sector with the base's angle, the graded waist's length and
the graded side seams' length, and is left alone where truing would break a seam."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from seamfit.pattern import load_pattern
from seamfit.pattern.checks import output_checks
from seamfit.pattern.model import Stitch, StitchSide, polyline_length
from seamfit.pattern.refit import refit_pattern
from seamfit.pattern.sectors import annular_sectors, fit_circle, true_sectors
from common import SAMPLES

CIRCLE = SAMPLES / "patterns/gc_circle_skirt/size06/pattern.json"
NOT_SECTORS = ["patterns/gc_pencil_skirt/size06/pattern.json", "patterns/fs_bodice/size06/pattern.json"]


def _outlines(p):
    return {q.name: np.array(q.outline_cm, dtype=float) for q in p.panels}


def _distorted(base):
    """The graded outlines as a search leaves them: wider across than along, and noisy."""
    rng = np.random.default_rng(3)
    out = {}
    for q in base.panels:
        o = np.array(q.outline_cm, dtype=float)
        c = o.mean(axis=0)
        out[q.name] = c + (o - c) * np.array([1.06, 1.02]) + rng.normal(0.0, 0.02, o.shape)
    return out


def _angles(o, centre, run):
    d = o[run] - centre
    return np.unwrap(np.arctan2(d[:, 1], d[:, 0]))


def test_the_circle_skirt_panels_are_sectors_and_other_panels_are_not():
    secs = annular_sectors(load_pattern(CIRCLE))
    assert sorted(s["panel"] for s in secs) == ["skirt_back", "skirt_front"]
    for s in secs:
        assert 10.0 < s["r_in"] < s["r_out"]
        assert len(s["sides"]) == 2
    for rel in NOT_SECTORS:
        assert annular_sectors(load_pattern(SAMPLES / rel)) == []


def test_an_untouched_sector_is_left_as_it_is():
    base = load_pattern(CIRCLE)
    outlines = _outlines(base)
    before = {k: v.copy() for k, v in outlines.items()}
    moved, _ = true_sectors(base, outlines)
    assert set(moved) == {"skirt_back", "skirt_front"}
    for k in outlines:                              # to the files' 1e-4 cm rounding
        np.testing.assert_allclose(outlines[k], before[k], atol=5e-4)


def test_a_distorted_sector_comes_out_a_sector_with_the_base_angle_and_the_graded_lengths():
    base = load_pattern(CIRCLE)
    outlines = _distorted(base)
    graded = {k: v.copy() for k, v in outlines.items()}
    moved, _ = true_sectors(base, outlines)
    for s in annular_sectors(base):
        name, o, g = s["panel"], outlines[s["panel"]], graded[s["panel"]]
        assert moved[name] > 1.0                                  # it did move (mm)
        inner = np.concatenate(s["inner"])
        outer = np.concatenate(s["outer"])
        c, r_in, rms_in = fit_circle(o[inner])
        c2, r_out, rms_out = fit_circle(o[outer])
        assert rms_in < 1e-12 * r_in and rms_out < 1e-12 * r_out    # true arcs
        assert np.linalg.norm(c - c2) < 1e-8                       # about one centre
        # the base's angle
        ob = np.asarray(base.panel(name).outline_cm, dtype=float)
        a_new, a_base = _angles(o, c, inner), _angles(ob, s["centre"], inner)
        assert abs(abs(a_new[-1] - a_new[0]) - abs(a_base[-1] - a_base[0])) < 1e-9
        # the graded waist's length, and both side seams the graded sides' mean length
        assert sum(polyline_length(o[run]) for run in s["inner"]) == pytest.approx(
            sum(polyline_length(g[run]) for run in s["inner"]), rel=1e-12)
        sides = [polyline_length(o[run]) for run in s["sides"]]
        assert sides[0] == pytest.approx(sides[1], rel=1e-12)
        assert sides[0] == pytest.approx(np.mean([polyline_length(g[run]) for run in s["sides"]]), rel=1e-6)
        # straight side seams
        for run in s["sides"]:
            d = o[run] - o[run[0]]
            assert np.max(np.abs(d[:, 0] * d[-1, 1] - d[:, 1] * d[-1, 0])) < 1e-3 * np.linalg.norm(d[-1])   # within 10 um of the chord


def test_truing_opens_no_seam_and_the_trued_skirt_refits():
    base = load_pattern(CIRCLE)
    plain = _distorted(base)
    trued = {k: v.copy() for k, v in plain.items()}
    true_sectors(base, trued)
    before = output_checks(base, refit_pattern(base, plain).pattern)["stitches"]
    refit = refit_pattern(base, trued)
    after = output_checks(base, refit.pattern)["stitches"]
    for b, a in zip(before, after):
        assert a["seam_mismatch_mm"] <= b["seam_mismatch_mm"] + 0.2, a["name"]
    failed_panels = {str(f[0]) for f in refit.failed}
    assert not failed_panels & {s["panel"] for s in annular_sectors(base)}


def test_sides_graded_apart_are_left_alone():
    base = load_pattern(CIRCLE)
    outlines = _distorted(base)
    s = annular_sectors(base)[0]
    o = outlines[s["panel"]]
    run = s["sides"][0]
    o[run] += np.linspace(0.0, 1.0, len(run))[:, None] * (o[run[-1]] - o[run[0]]) * 0.02   # 2 % longer
    before = o.copy()
    moved, _ = true_sectors(base, outlines)
    assert s["panel"] not in moved
    np.testing.assert_array_equal(outlines[s["panel"]], before)


def test_a_sector_whose_hem_is_stitched_is_not_trued():
    base = load_pattern(CIRCLE)
    s = annular_sectors(base)[0]
    hem = s["outer"][0]
    other = next(q for q in base.panels if q.name != s["panel"])
    stitch = Stitch(kind="seam", a=StitchSide(panel=s["panel"], range=(int(hem[0]), int(hem[-1]))),
                    b=StitchSide(panel=other.name, range=(0, 3)), orientation="reversed")
    frilled = dataclasses.replace(base, stitches=list(base.stitches) + [stitch])
    assert s["panel"] not in {x["panel"] for x in annular_sectors(frilled)}


def test_points_inside_the_panel_go_through_the_same_map():
    base = load_pattern(CIRCLE)
    outlines = _distorted(base)
    s = annular_sectors(base)[0]
    ob = np.asarray(base.panel(s["panel"]).outline_cm, dtype=float)
    # the base outline itself, and a point halfway between the waist and the hem
    mid_run = s["sides"][0]
    inside = 0.5 * (ob[mid_run[0]] + ob[mid_run[-1]])[None, :]
    _, carried = true_sectors(base, outlines, carry={s["panel"]: np.vstack([ob, inside])})
    o = outlines[s["panel"]]
    np.testing.assert_allclose(carried[s["panel"]][:-1], o, atol=5e-4)   # the files' rounding
    np.testing.assert_allclose(carried[s["panel"]][-1], 0.5 * (o[mid_run[0]] + o[mid_run[-1]]), atol=5e-4)
