"""body_measurements' memo (seamfit.body.measure._remembered): a grading measures the same
two bodies several times; the repeats are copies of the first measurement, the same numbers
as measuring afresh, and no caller's edit reaches another caller."""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import Body, body_measurements, load_body
from seamfit.body import measure
from common import SAMPLES

BODIES = SAMPLES / "bodies"
LANDMARKS = BODIES / "landmarks.json"


@pytest.fixture(scope="module")
def body():
    return load_body(BODIES / "women_size06.obj")


@pytest.fixture
def counted(monkeypatch):
    """The number of measurements actually taken (memo misses), from an empty memo."""
    monkeypatch.setattr(measure, "_memo", type(measure._memo)())
    taken = []
    real = measure._measure

    def counting(*args, **kwargs):
        taken.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(measure, "_measure", counting)
    return taken


@pytest.mark.parametrize("landmarks", [None, LANDMARKS])
def test_a_repeat_is_free_and_equal_to_a_fresh_measurement(body, counted, landmarks):
    first = body_measurements(body, landmarks=landmarks)
    again = body_measurements(body, landmarks=landmarks)
    assert len(counted) == 1
    fresh = measure._measure(body, landmarks, tapes=False)
    assert first == again == fresh
    # bit for bit, not merely equal within float tolerance
    assert json.dumps(first, sort_keys=True) == json.dumps(fresh, sort_keys=True)


def test_the_same_mesh_loaded_twice_and_landmarks_read_or_given_share_an_entry(body, counted):
    body_measurements(body, landmarks=LANDMARKS)
    body_measurements(load_body(BODIES / "women_size06.obj"), landmarks=json.loads(LANDMARKS.read_text()))
    assert len(counted) == 1
    body_measurements(body)                  # without landmarks: a measurement of its own
    assert len(counted) == 2


def test_an_edited_result_does_not_reach_later_calls(body, counted):
    first = body_measurements(body)
    expected = json.dumps(first, sort_keys=True)
    first["hip"] = -1.0
    first["levels_z_m"]["waist"] = -1.0      # nested values too
    first["extra"] = "x"
    again = body_measurements(body)
    assert json.dumps(again, sort_keys=True) == expected
    assert again is not first and again["levels_z_m"] is not first["levels_z_m"]
    assert len(counted) == 1


def test_a_different_mesh_misses_the_memo(body, counted):
    before = body_measurements(body)
    scaled = Body(body.vertices * 1.02, body.faces, name="scaled")
    after = body_measurements(scaled)
    assert len(counted) == 2
    assert after["height"] == pytest.approx(1.02 * before["height"], rel=1e-9)
    # a body changed in place is measured again
    moved = Body(body.vertices * 1.0, body.faces, name="moved")
    assert body_measurements(moved) == before and len(counted) == 2
    moved.vertices[:, 2] *= 1.01
    body_measurements(moved)
    assert len(counted) == 3


def test_with_tapes_each_call_measures_afresh(body, counted):
    a = body_measurements(body, landmarks=LANDMARKS, tapes=True)
    b = body_measurements(body, landmarks=LANDMARKS, tapes=True)
    assert len(counted) == 2 and a["tapes"] is not b["tapes"]


def test_the_memo_keeps_only_the_last_few(monkeypatch):
    monkeypatch.setattr(measure, "_memo", type(measure._memo)())
    taken = []
    monkeypatch.setattr(measure, "_measure",
                        lambda b, lm, tapes: taken.append(1) or {"height": float(b.vertices[0, 0])})
    faces = np.array([[0, 1, 2]], dtype=np.int64)
    bodies = [Body(np.full((3, 3), float(i)), faces, name=str(i)) for i in range(measure._MEMO_SIZE + 2)]
    for b in bodies:
        body_measurements(b)
    assert len(measure._memo) == measure._MEMO_SIZE
    body_measurements(bodies[-1])            # recent: remembered
    assert len(taken) == len(bodies)
    body_measurements(bodies[0])             # the oldest was let go
    assert len(taken) == len(bodies) + 1
    assert len(measure._memo) == measure._MEMO_SIZE
