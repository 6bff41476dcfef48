"""Body measurements against the sample bodies' measured values (measurements.json).

Tolerances: with landmarks the levels follow the data's own definitions, so the
girths agree to 0.5 cm (bust, hip) and 1 cm (waist: the level is the mean of four
waist-ring landmarks, about 4 mm above the mean of the whole ring). Without
landmarks, bust and hip agree to 1 cm; the heuristic waist is the minimum torso
girth, compared with the data's `min_trunk_girth_between_underbust_and_hip`
(the data's own waist is MakeHuman's natural-waist ring, 3-5 cm larger).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import Body, body_measurements, cross_section_girth, load_body
from seamfit.errors import BodyError
from common import SAMPLES

BODIES = SAMPLES / "bodies"
MEASURED = json.loads((BODIES / "measurements.json").read_text())["bodies"]
LANDMARKS = BODIES / "landmarks.json"
NAMES = ["women_size06", "women_size10", "women_apple"]


@pytest.fixture(scope="module", params=NAMES)
def named_body(request):
    return request.param, load_body(BODIES / f"{request.param}.obj")


def test_with_landmarks(named_body):
    name, body = named_body
    ref = MEASURED[name]["achieved_cm"]
    levels = MEASURED[name]["measurement_levels_z_m"]
    m = body_measurements(body, landmarks=LANDMARKS)
    assert m["method"] == "landmarks"
    assert m["height"] == pytest.approx(ref["height"], abs=0.05)
    assert m["bust"] == pytest.approx(ref["bust"], abs=0.5)
    assert m["hip"] == pytest.approx(ref["hip"], abs=0.5)
    assert m["waist"] == pytest.approx(ref["waist"], abs=1.0)
    lv = m["levels_z_m"]
    assert lv["crotch"] == pytest.approx(levels["crotch_z"], abs=0.002)
    assert lv["armpit"] == pytest.approx(levels["armpit_z"], abs=0.003)
    assert lv["hip"] == pytest.approx(levels["hip_z"], abs=0.02)
    assert lv["waist"] == pytest.approx(levels["waist_z"], abs=0.01)


def test_heuristic_levels(named_body):
    name, body = named_body
    ref = MEASURED[name]["achieved_cm"]
    m = body_measurements(body)
    assert m["method"] == "heuristic"
    assert m["height"] == pytest.approx(ref["height"], abs=0.05)
    assert m["bust"] == pytest.approx(ref["bust"], abs=1.0)
    assert m["hip"] == pytest.approx(ref["hip"], abs=1.0)
    min_trunk = MEASURED[name]["other_measurements_cm"]["min_trunk_girth_between_underbust_and_hip"]
    assert m["waist"] == pytest.approx(min_trunk, abs=0.5)
    assert m["levels_z_m"]["crotch"] == pytest.approx(MEASURED[name]["measurement_levels_z_m"]["crotch_z"],
                                                      abs=0.01)
    # the documented gap: the natural waist is larger than the minimum girth
    assert ref["waist"] - m["waist"] > 2.0


def test_girths_grade_with_size():
    small = body_measurements(load_body(BODIES / "women_size06.obj"))
    large = body_measurements(load_body(BODIES / "women_size10.obj"))
    for key in ("bust", "waist", "hip"):
        assert large[key] > small[key] + 3.0


def test_tape_girth_of_a_box_and_a_concave_section():
    # a 0.4 x 0.3 box, 1 m tall: perimeter 1.4 m at any level
    V = np.array([[x, y, z] for z in (0, 1) for y in (-0.15, 0.15) for x in (-0.2, 0.2)], float)
    F = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
    box = Body(V, F, name="box")
    assert cross_section_girth(box, 0.5) == pytest.approx(1.4, abs=1e-12)
    # an L-shaped prism: the tape bridges the notch (convex hull), it does not follow it
    P = np.array([[0, 0], [0.4, 0], [0.4, 0.1], [0.1, 0.1], [0.1, 0.3], [0, 0.3]], float) - [0.05, 0.15]
    n = len(P)
    V = np.vstack([np.c_[P, np.zeros(n)], np.c_[P, np.ones(n)]])
    side = [[i, (i + 1) % n, n + i] for i in range(n)] + [[(i + 1) % n, n + (i + 1) % n, n + i] for i in range(n)]
    caps = [[0, j + 1, j] for j in range(1, n - 1)] + [[n, n + j, n + j + 1] for j in range(1, n - 1)]
    ell = Body(V, np.array(side + caps), name="ell")
    hull = 0.4 + 0.1 + np.hypot(0.3, 0.2) + 0.1 + 0.3  # the notch (perimeter 1.4) is bridged
    assert cross_section_girth(ell, 0.5) == pytest.approx(hull, abs=1e-12)


def test_missing_landmark_is_an_error():
    body = load_body(BODIES / "women_size06.obj")
    with pytest.raises(BodyError, match="landmark 'crotch' missing"):
        body_measurements(body, landmarks={"waist_front": 4121})
    with pytest.raises(BodyError, match="not a body height"):
        body_measurements(Body(body.vertices * 100, body.faces, name="cm"))


def test_a_remembered_measurement_is_the_same_and_a_copy():
    from seamfit.body import measure
    body = load_body(BODIES / "women_size06.obj")
    measure._memo.clear()
    first = body_measurements(body, landmarks=LANDMARKS)
    fresh = measure._measure(body, LANDMARKS, tapes=False)
    again = body_measurements(load_body(BODIES / "women_size06.obj"), landmarks=json.loads(LANDMARKS.read_text()))
    assert first == fresh == again
    first["levels_z_m"]["waist"] = -1.0      # a caller's edit does not reach the next caller
    assert body_measurements(body, landmarks=LANDMARKS)["levels_z_m"]["waist"] == fresh["levels_z_m"]["waist"]
    # without landmarks, another measurement (its own levels)
    assert body_measurements(body)["method"] == "heuristic"


def test_a_body_changed_in_place_is_measured_again():
    body = load_body(BODIES / "women_size06.obj")
    before = body_measurements(body)
    body.vertices *= 1.05
    after = body_measurements(body)
    assert after["height"] == pytest.approx(1.05 * before["height"], rel=1e-9)
    assert after["hip"] > before["hip"]
