"""Proportional scaling (the grading baseline): landmarks move by the known ratios about the
bounding-box centre, the ratios come from the right girth, and the scaled pattern survives a
sewpat-1 round trip unchanged."""
from __future__ import annotations


import numpy as np
import pytest

from seamfit.pattern import load_pattern, save_pattern
from seamfit.pattern.compare import landmark_errors
from seamfit.pattern.scale import (girth_for_garment, proportional_ratios, proportional_scale,
                                   scale_outline, scale_pattern)
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
PENCIL = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
BODICE = PATTERNS / "fs_bodice/size06/pattern.json"
SX, SY = 1.08, 0.97
TOL_CM = 0.051          # refit snaps outline points onto the curves, within 0.5 mm


@pytest.fixture(scope="module", params=[PENCIL, BODICE], ids=lambda p: p.parent.parent.name)
def pair(request):
    base = load_pattern(request.param)
    return base, scale_pattern(base, SX, SY)


def test_landmarks_move_by_the_ratios(pair):
    base, scaled = pair
    for bp, sp in zip(base.panels, scaled.panels):
        assert sp.landmarks == bp.landmarks and sp.n_vertices == bp.n_vertices
        o = bp.outline_cm
        c = 0.5 * (o.min(axis=0) + o.max(axis=0))
        idx = sorted(set(bp.landmarks.values()))
        want = c + (o[idx] - c) * [SX, SY]
        # landmarks are edge ends, which refitting never moves
        np.testing.assert_allclose(sp.outline_cm[idx], want, atol=1e-9)
        # the whole outline follows within the refit tolerance
        d = np.linalg.norm(sp.outline_cm - scale_outline(o, SX, SY), axis=1)
        assert d.max() < TOL_CM, (bp.name, d.max())


def test_base_untouched_and_identity(pair):
    base, _ = pair
    again = load_pattern(base.source_file)
    for a, b in zip(base.panels, again.panels):
        np.testing.assert_array_equal(a.outline_cm, b.outline_cm)
    same = scale_pattern(base, 1.0, 1.0)
    assert landmark_errors(same, base).max_cm < 1e-6


def test_round_trip(pair, tmp_path):
    _, scaled = pair
    path = save_pattern(scaled, tmp_path / "scaled.json")
    back = load_pattern(path)
    for a, b in zip(scaled.panels, back.panels):
        assert a.name == b.name and a.landmarks == b.landmarks
        np.testing.assert_allclose(b.outline_cm, a.outline_cm, atol=1e-4)   # stored to 1e-4 cm
        assert [e.kind for e in a.edges] == [e.kind for e in b.edges]
    assert landmark_errors(back, scaled).max_cm < 1e-3


def test_ratios_follow_the_garment():
    base = {"height": 165.0, "bust": 90.0, "waist": 70.0, "hip": 100.0}
    tgt = {"height": 178.0, "bust": 99.0, "waist": 84.0, "hip": 105.0}
    assert girth_for_garment("fitted_bodice") == "bust"
    assert girth_for_garment("tshirt") == "bust"
    assert girth_for_garment("circle_skirt") == "waist"
    assert girth_for_garment("pencil_skirt") == "hip"
    assert girth_for_garment("pants") == "hip"
    assert girth_for_garment(None) == "hip"
    r = proportional_ratios("pencil_skirt", base, tgt)
    assert r == {"girth": "hip", "sx": pytest.approx(1.05), "sy": pytest.approx(178 / 165)}
    with pytest.raises(ValueError):
        scale_pattern(load_pattern(PENCIL), 0.0, 1.0)


def test_proportional_scale_uses_pattern_type():
    base = load_pattern(BODICE)
    scaled, r = proportional_scale(base, {"height": 165.0, "bust": 90.0}, {"height": 165.0, "bust": 99.0})
    assert r["girth"] == "bust" and r["sx"] == pytest.approx(1.1) and r["sy"] == pytest.approx(1.0)
    w0 = np.ptp(base.panels[0].outline_cm[:, 0])
    assert np.ptp(scaled.panels[0].outline_cm[:, 0]) == pytest.approx(1.1 * w0, abs=TOL_CM)
