"""Body validation: statistics of the sample bodies, and every defect's error or warning."""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import Body, check_body, load_body, validate_body
from seamfit.errors import BodyError
from common import SAMPLES

BODIES = SAMPLES / "bodies"
MEASURED = json.loads((BODIES / "measurements.json").read_text())["bodies"]


@pytest.fixture(scope="module")
def body():
    return load_body(BODIES / "women_size06.obj")


@pytest.mark.parametrize("name", ["women_size06", "women_size10", "women_apple"])
def test_sample_bodies_are_clean(name):
    b = load_body(BODIES / f"{name}.obj")
    rep = check_body(b)
    assert rep.ok and rep.errors == [] and rep.warnings == []
    st = rep.stats
    assert st["watertight"] and st["manifold"] and st["consistently_oriented"] and not st["inverted"]
    assert st["boundary_edges"] == 0 and st["nonmanifold_edges"] == 0 and st["degenerate_faces"] == 0
    assert st["edges"] == 40134 and st["components"] == 1
    assert st["volume_litres"] == pytest.approx(MEASURED[name]["volume_litres"], abs=0.01)
    assert st["height_m"] * 100 == pytest.approx(MEASURED[name]["achieved_cm"]["height"], abs=0.01)
    np.testing.assert_array_equal(rep.oriented_faces, b.faces)


def test_nan_vertex_is_an_error_naming_it(body):
    V = body.vertices.copy()
    V[[17, 4000]] = [np.nan, 0, np.inf]
    b = Body(V, body.faces, name="n", source_file="n.obj")
    rep = validate_body(b)
    assert len(rep.errors) == 1 and "n.obj" in rep.errors[0] and "vertex 17, 4000" in rep.errors[0]
    with pytest.raises(BodyError, match="NaN or infinite.*vertex 17"):
        check_body(b)


def test_no_faces_and_bad_indices(body):
    assert "no faces" in validate_body(Body(body.vertices, np.zeros((0, 3)), name="e")).errors[0]
    F = body.faces.copy()
    F[123, 1] = 99999
    F[200, 0] = -1
    err = validate_body(Body(body.vertices, F, name="idx")).errors[0]
    assert "2 faces refer to vertices outside 0..13379" in err and "face 123, 200" in err


@pytest.mark.parametrize("scale, word", [(1000.0, "millimetres"), (100.0, "centimetres"), (0.1, "tall")])
def test_implausible_units(body, scale, word):
    rep = validate_body(Body(body.vertices * scale, body.faces, name="u"))
    assert len(rep.errors) == 1 and word in rep.errors[0] and "metres" in rep.errors[0]


def test_open_mesh_is_a_warning(body):
    b = Body(body.vertices, np.delete(body.faces, [10, 11, 5000], axis=0), name="open")
    rep = check_body(b)
    assert rep.ok and not rep.watertight and rep.stats["boundary_edges"] > 0
    assert any("open" in w and "generalized winding number" in w for w in rep.warnings)


def test_nonmanifold_edge_is_a_warning(body):
    a, c = body.faces[0, 0], body.faces[0, 1]
    V = np.vstack([body.vertices, body.vertices[a] + [0.0, 0.0, 0.01]])
    fin = [[a, c, len(body.vertices)]]
    rep = check_body(Body(V, np.vstack([body.faces, fin]), name="fin"))
    assert rep.stats["nonmanifold_edges"] == 1 and not rep.stats["manifold"]
    assert any("non-manifold" in w and f"({min(a, c)}, {max(a, c)})" in w for w in rep.warnings)


def test_inconsistent_orientation_is_repaired(body):
    F = body.faces.copy()
    flipped = np.arange(0, len(F), 97)
    F[flipped] = F[flipped][:, ::-1]
    rep = check_body(Body(body.vertices, F, name="mixed"))
    assert not rep.stats["consistently_oriented"]
    assert any("opposite orientation" in w and f"{len(flipped)} faces are flipped" in w for w in rep.warnings)
    np.testing.assert_array_equal(rep.oriented_faces, body.faces)


def test_inside_out_body_is_repaired(body):
    rep = check_body(Body(body.vertices, body.faces[:, ::-1], name="inv"))
    assert rep.stats["inverted"] and rep.stats["signed_volume_m3"] < 0
    assert any("inside-out" in w for w in rep.warnings)
    np.testing.assert_array_equal(rep.oriented_faces, body.faces)


def test_non_orientable_surface_is_an_error():
    # A Moebius strip, 1 m tall: no consistent orientation exists.
    n, u = 40, np.linspace(0, 2 * np.pi, 40, endpoint=False)
    rows = []
    for s in (-0.1, 0.1):
        rows.append(np.stack([(0.5 + s * np.cos(u / 2)) * np.cos(u), s * np.sin(u / 2),
                              0.5 + (0.5 + s * np.cos(u / 2)) * np.sin(u)], axis=1))
    V = np.vstack(rows)
    F = []
    for i in range(n):
        j = (i + 1) % n
        a, b = i, n + i
        c, d = (j, n + j) if j else (n + j, j)  # the half twist swaps the sides
        F += [[a, c, b], [b, c, d]]
    rep = validate_body(Body(V, np.array(F), name="moebius"))
    assert any("not orientable" in e for e in rep.errors)
    with pytest.raises(BodyError, match="not orientable"):
        check_body(Body(V, np.array(F), name="moebius"))


def test_flat_sheet_encloses_no_volume():
    V = np.array([[0, 0, 0], [0.5, 0, 0], [0.5, 0, 1.6], [0, 0, 1.6]], float)
    rep = validate_body(Body(V, [[0, 1, 2], [0, 2, 3]], name="sheet"))
    assert any("encloses no volume" in e for e in rep.errors)


def test_degenerate_faces_and_up_axis_warnings(body):
    F = np.vstack([body.faces, [[5, 5, 6]], [[7, 8, 7]]])
    rep = check_body(Body(body.vertices, F, name="deg"))
    assert rep.stats["degenerate_faces"] == 2
    assert any("2 degenerate" in w and "26756, 26757" in w for w in rep.warnings)
    y_up = body.vertices[:, [0, 2, 1]] * [1, 1, 1]
    rep = validate_body(Body(y_up, body.faces[:, ::-1], name="yup"))
    assert any("longest extent is along Y" in w for w in rep.warnings)
