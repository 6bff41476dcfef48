"""Ease as a tape measures it (seamfit.opt.fit): around the torso under the arms, and only
where the garment goes around the torso."""
from __future__ import annotations


import numpy as np
import pytest

from seamfit.body import body_measurements, load_body
from seamfit.body.measure import _Slicer
from seamfit.opt.fit import EASE_LOSS_CM, ease_losses, ease_report, mesh_cross_section

from opt_synthetic import merge
from common import SAMPLES

BODY = SAMPLES / "bodies" / "women_size06.obj"
N = 64


def tube(centre, r, z, arc=2 * np.pi, h=0.05):
    """A vertical tube of cloth (or an open arc of it) from z - h to z + h."""
    closed = arc >= 2 * np.pi
    a = np.linspace(0, arc, N, endpoint=not closed)
    ring = np.c_[centre[0] + r * np.cos(a), centre[1] + r * np.sin(a)]
    V = np.vstack([np.c_[ring, np.full(N, z - h)], np.c_[ring, np.full(N, z + h)]])
    F = []
    for i in range(N if closed else N - 1):
        j = (i + 1) % N
        F += [[i, j, N + i], [j, N + j, N + i]]
    return V, np.array(F)


@pytest.fixture(scope="module")
def at_bust():
    body = load_body(BODY)
    levels = body_measurements(body)["levels_z_m"]
    s = _Slicer(body)
    z = levels["bust"]
    keep, _ = s.torso(z)
    loops = [(any(segs is k for k in keep), segs.reshape(-1, 2)) for segs in s.loops(z)]
    assert sum(t for t, _ in loops) == 1 and len(loops) == 3      # torso and two arms
    # each loop wrapped in a tube 1 cm out: a t-shirt's body and its sleeves
    tubes = [(t, p.mean(axis=0), np.linalg.norm(p - p.mean(axis=0), axis=1).max() + 0.01) for t, p in loops]
    return body, levels, s, z, tubes


def test_the_tape_goes_around_the_torso_not_the_sleeves(at_bust):
    body, levels, s, z, tubes = at_bust
    x, tri = merge(*[tube(c, r, z) for _, c, r in tubes])
    (_, c, r), = [t for t in tubes if t[0]]
    torso_girth = 2 * N * r * np.sin(np.pi / N)          # the body tube's polygon
    ease = ease_report(body, x, tri, levels)
    assert ease["bust"] == pytest.approx(100 * (torso_girth - s.girth(z)), abs=0.01)
    from seamfit.body.measure import _hull_perimeter
    around_sleeves = 100 * (_hull_perimeter(mesh_cross_section(x, tri, z)) - s.girth(z))
    assert around_sleeves > ease["bust"] + 10            # what the hull round everything reads
    assert ease["waist"] is None and ease["hip"] is None  # the tubes end above them


def test_a_garment_that_does_not_go_around_has_no_girth_there(at_bust):
    body, levels, s, z, tubes = at_bust
    (_, c, r), = [t for t in tubes if t[0]]
    x, tri = tube(c, r, z, arc=np.pi)                    # the front half only
    assert ease_report(body, x, tri, levels)["bust"] is None
    x, tri = tube(c, r, z, arc=1.9 * np.pi)              # a gap a tape bridges
    assert ease_report(body, x, tri, levels)["bust"] is not None


def test_the_bust_s_ease_is_taken_over_the_bust_points():
    """On a body of MakeHuman's mesh the bust's ease is taken at the bust points' height
    (the fullest girth of a small bust lies under the arms, where a sleeveless bodice is
    open at its armholes); the waist and hip stay at the body's measuring levels, and a body
    of another mesh keeps its bust level."""
    from dataclasses import replace
    from seamfit.body import hm08_landmarks
    from seamfit.opt.fit import ease_levels
    body = load_body(BODY)
    lm = hm08_landmarks()
    measured = body_measurements(body)["levels_z_m"]
    levels = ease_levels(body)
    apex = float(np.mean(body.vertices[[lm["bust_point_L"], lm["bust_point_R"]], 2]))
    assert levels["bust"] == pytest.approx(apex, abs=1e-12)
    assert levels["waist"] == measured["waist"] and levels["hip"] == measured["hip"]
    v = np.array(body.vertices, dtype=float)
    v[[lm["bust_point_L"], lm["bust_point_R"]], 2] -= 0.02      # the apex 2 cm lower
    assert ease_levels(replace(body, vertices=v))["bust"] == pytest.approx(apex - 0.02, abs=1e-12)
    other = replace(body, faces=np.asarray(body.faces)[::-1].copy())
    assert ease_levels(other)["bust"] == measured["bust"]


def test_a_level_that_lost_its_ease_is_named_with_the_numbers():
    base = {"bust": 3.11, "waist": 24.3, "hip": None}
    # a t-shirt graded two sizes up keeping 0.45 cm at the bust: tighter than its base
    (line,) = ease_losses(base, {"bust": 0.45, "waist": 24.7, "hip": None})
    assert "at the bust" in line and "+0.5 cm of ease" in line and "+3.1 cm" in line
    # looser, or a few millimetres off, or a flare that keeps most of its ease: nothing to say
    assert ease_losses(base, {"bust": 4.7, "waist": 30.0, "hip": None}) == []
    assert ease_losses({"hip": 0.73}, {"hip": 0.2}) == []
    assert ease_losses({"hip": 17.0}, {"hip": 12.9}) == []
    # ease gone below the body's girth, by more than EASE_LOSS_CM in all
    (line,) = ease_losses({"hip": 0.73}, {"hip": 0.73 - EASE_LOSS_CM - 0.05})
    assert "at the hip" in line and "-0.3 cm of ease" in line
    # a level either drape does not reach is not compared
    assert ease_losses({"bust": 3.0, "hip": None}, {"bust": None, "hip": 1.0}) == []
    assert ease_losses(None, None) == []
