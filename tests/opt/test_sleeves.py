"""Sleeves graded around the arm (seamfit.opt.sleeves): the arm's centre line, which panels
are sleeves, and a sleeve's girth stretch from the arm section it encloses."""
from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from common import SAMPLES



@pytest.fixture(scope="module")
def body_arms():
    from seamfit.body import load_body
    from seamfit.opt.level_scale import base_levels
    from seamfit.opt.sleeves import arm_lines
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    levels = base_levels(body)
    return body, levels, arm_lines(body, levels)


def _tube(arm, samples, radius, m=24):
    """A triangulated tube of cloth around the arm's centre line at ``samples``."""
    from seamfit.opt.sleeves import _frame
    rings = []
    ang = 2 * np.pi * np.arange(m) / m
    for k in samples:
        R = _frame(arm["A"][k])
        rings.append(arm["P"][k] + radius * (np.cos(ang)[:, None] * R[0] + np.sin(ang)[:, None] * R[1]))
    x = np.vstack(rings)
    tri = []
    for i in range(len(samples) - 1):
        for j in range(m):
            a, b = i * m + j, i * m + (j + 1) % m
            tri += [[a, b, a + m], [b, b + m, a + m]]
    return x, np.array(tri)


def _arm_widened(body, arm, k):
    """The body with the arm's vertices below the armpit moved out from its centre line by k."""
    from scipy.spatial import cKDTree
    v = np.array(body.vertices, dtype=float)
    ids = arm["vertices"]
    _, near = cKDTree(arm["P"]).query(v[ids])
    d = v[ids] - arm["P"][near]
    a = arm["A"][near]
    radial = d - np.sum(d * a, axis=1, keepdims=True) * a
    v[ids] += (k - 1.0) * radial
    return replace(body, vertices=v)


def test_each_arm_has_a_centre_line_down_and_out_from_the_armpit(body_arms):
    body, levels, arms = body_arms
    assert len(arms) == 2
    v = np.asarray(body.vertices)
    sides = set()
    for arm in arms:
        P, A = arm["P"], arm["A"]
        side = np.sign(P[-1, 0])
        sides.add(side)
        assert np.all(A[:, 2] < 0)                        # down the arm
        assert np.all(side * A[:, 0] > 0)                 # and out (A-pose)
        assert np.all(np.diff(P[:, 2]) < 0)
        arm_v = v[arm["vertices"]]
        assert np.all(arm_v[:, 2] < levels["armpit"])     # the arm below the armpit only
        assert np.all(side * arm_v[:, 0] > 0.1)           # all on its side, clear of the torso
    assert sides == {1.0, -1.0}


def test_a_tube_round_the_arm_is_a_sleeve_and_a_ring_round_the_torso_is_not(body_arms):
    from seamfit.opt.sleeves import CAP_SAMPLES, sleeve_panels
    body, levels, arms = body_arms
    arm = arms[0]
    sleeve, _ = _tube(arm, range(CAP_SAMPLES - 4, CAP_SAMPLES + 12), 1.4 * arm["radius"])
    z = levels["waist"]
    ang = 2 * np.pi * np.arange(48) / 48
    torso = np.column_stack([0.16 * np.cos(ang), 0.05 + 0.12 * np.sin(ang), np.full(48, z)])
    mesh = SimpleNamespace(vertex_panel=np.r_[np.zeros(len(sleeve), int), np.ones(48, int)],
                           panel_names=["sleeve", "body"])
    assert list(sleeve_panels(mesh, np.vstack([sleeve, torso]), body, arms)) == [0, -1]


def test_a_sleeve_grows_by_what_the_arm_section_inside_it_grew(body_arms):
    from seamfit.opt.sleeves import CAP_SAMPLES, _arm_profile
    body, levels, arms = body_arms
    arm = arms[0]
    samples = list(range(CAP_SAMPLES + 1, CAP_SAMPLES + 14))
    x, tri = _tube(arm, samples, 1.4 * arm["radius"])

    def x_rot_tri(origin, R):
        return (x - origin) @ R.T, tri

    same = _arm_profile(arm, body, body, x_rot_tri)
    assert np.all(same["sx"] == 1.0)
    k = 1.1
    grown = _arm_profile(arm, body, _arm_widened(body, arm, k), x_rot_tri)
    ok = np.isfinite(grown["dH"])
    inner = [s for s in samples[2:-2] if ok[s]]
    assert len(inner) >= 5
    # the arm's section grew by k about the centre line, so its girth by (k - 1) of it
    np.testing.assert_allclose(grown["dH"][inner], (k - 1) * grown["H"][inner], rtol=0.1)
    np.testing.assert_allclose(grown["sx"][inner], 1 + grown["dH"][inner] / grown["G"][inner], rtol=1e-12)
    assert np.all(grown["G"][inner] > grown["H"][inner])     # the cloth goes round the arm
    assert np.all(np.isfinite(grown["sx"]))


def test_a_garment_without_sleeves_keeps_its_levels(body_arms):
    from seamfit.opt.sleeves import sleeve_targets
    body, levels, _ = body_arms
    z = levels["waist"]
    ang = 2 * np.pi * np.arange(48) / 48
    ring = [np.column_stack([0.16 * np.cos(ang), 0.05 + 0.12 * np.sin(ang), np.full(48, z + dz)]) for dz in (0, 0.03)]
    x = np.vstack(ring)
    tri = np.array([[j, (j + 1) % 48, j + 48] for j in range(48)])
    mesh = SimpleNamespace(triangles=tri, vertex_panel=np.zeros(96, int), panel_names=["body"])
    mask, sx, up = sleeve_targets(mesh, x, body, body, levels)
    assert not mask.any() and np.all(sx == 1.0) and np.all(up == [0.0, 0.0, 1.0])


def test_an_arm_joined_to_the_body_lower_down_keeps_only_its_own_vertices(body_arms):
    from seamfit.opt.sleeves import arm_lines
    body, levels, arms = body_arms
    v = np.asarray(body.vertices)
    arm = max(arms, key=lambda a: a["P"][-1, 0])            # the arm on +x
    hand = arm["vertices"][np.argmin(v[arm["vertices"], 2])]
    # a triangle from the hand's lowest vertex to the two nearest vertices of the other
    # side's hip makes the arm and the torso one piece of mesh below the armpit
    torso = np.flatnonzero((np.abs(v[:, 0]) < 0.12) & (v[:, 2] < levels["armpit"] - 0.1))
    near = torso[np.argsort(np.linalg.norm(v[torso] - v[hand], axis=1))[:2]]
    joined = replace(body, faces=np.vstack([body.faces, [[hand, near[0], near[1]]]]).astype(body.faces.dtype))
    arms2 = arm_lines(joined, levels)
    right = [a for a in arms2 if a["P"][-1, 0] > 0]
    assert len(right) == 1
    assert np.all(v[right[0]["vertices"], 0] > 0.1)           # no torso vertex is the arm's


def test_a_sleeve_no_plane_measures_keeps_the_torso_s_levels(body_arms, monkeypatch):
    from seamfit.opt import sleeves
    body, levels, arms = body_arms
    arm = arms[0]
    x, tri = _tube(arm, range(sleeves.CAP_SAMPLES + 1, sleeves.CAP_SAMPLES + 14), 1.4 * arm["radius"])
    mesh = SimpleNamespace(triangles=tri, vertex_panel=np.zeros(len(x), int), panel_names=["sleeve"])
    mask, sx, up = sleeves.sleeve_targets(mesh, x, body, _arm_widened(body, arm, 1.1), levels)
    assert mask.all() and np.all(sx > 1.0)                    # measured around the arm
    assert np.allclose(np.linalg.norm(up, axis=1), 1.0) and np.all(up[:, 2] > 0)

    def unmeasured(arm, base_body, target_body, x_rot_tri):
        n = len(arm["P"])
        return {"sx": np.ones(n), "G": np.full(n, np.nan), "H": np.full(n, np.nan), "dH": np.full(n, np.nan)}
    monkeypatch.setattr(sleeves, "_arm_profile", unmeasured)
    mask, sx, up = sleeves.sleeve_targets(mesh, x, body, body, levels)
    assert not mask.any() and np.all(sx == 1.0)
