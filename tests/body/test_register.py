"""Any mesh as a target (seamfit.body.register, ``seamfit body --register``, grade).

A decimated copy (fast-simplification's quadric decimation) and a remeshed copy
(gpytoolbox's isotropic remeshing) of a sample body register back onto it: the
registered body has the sample bodies' mesh, lies on the copy's surface, and its vertices
land within 5 mm (mean) of the sample body's own. Meshes that cannot be registered get a
one-line error naming the reason before any fitting; grade registers a target of another
mesh on its own.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import Body, RegistrationError, check_registrable, hm08_landmarks, load_body, save_body
from seamfit.body.closest import SurfaceIndex, closest_on_triangles
from seamfit.cli import main
from common import SAMPLES, run_cli as cli

BODIES = SAMPLES / "bodies"
BASE = BODIES / "women_size06.obj"
SAMPLE = BODIES / "women_apple.obj"          # an individual, far from the base body's shape


def decimated(body: Body) -> Body:
    import fast_simplification
    V, F = fast_simplification.simplify(body.vertices, body.faces.astype(np.int64), target_reduction=0.8)
    return Body(V, F, name="decimated")


def remeshed(body: Body) -> Body:
    import gpytoolbox
    V, F = gpytoolbox.remesh_botsch(body.vertices, body.faces.astype(np.int32), i=10, h=0.012, project=True)
    return Body(V, F, name="remeshed")


def assert_one_line_error(code, err, *words):
    assert code == 2, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("seamfit body: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.fixture(scope="module", params=["decimated", "remeshed"])
def registered(request, tmp_path_factory):
    """A copy of the sample body, registered by ``seamfit body --register``."""
    folder = tmp_path_factory.mktemp(request.param)
    sample = load_body(SAMPLE)
    copy = (decimated if request.param == "decimated" else remeshed)(sample)
    assert copy.n_vertices != sample.n_vertices
    scan = save_body(copy, folder / f"{request.param}.obj")
    before = scan.read_bytes()
    out = folder / "body.obj"
    assert main(["body", "--register", str(scan), "--out", str(out), "-q"]) == 0
    assert scan.read_bytes() == before                      # the input is never touched
    report = json.loads((folder / "body.report.json").read_text())["registration"]
    return sample, copy, load_body(out), report


def test_a_copy_registers_back_onto_the_sample_body(registered):
    sample, copy, body, report = registered
    base = load_body(BASE)
    assert np.array_equal(body.faces, base.faces)           # the base body's mesh: grading's correspondence
    # on the copy's surface: the distances measured here are the report's
    d = SurfaceIndex(copy.vertices, copy.faces).query(body.vertices)[0] * 1000
    assert report["error_mm"]["mean"] == pytest.approx(d.mean(), abs=0.01)
    assert report["error_mm"]["max"] == pytest.approx(d.max(), abs=0.01)
    assert d.mean() < 5.0
    # and every vertex back where the sample body has it
    err = np.linalg.norm(body.vertices - sample.vertices, axis=1) * 1000
    assert err.mean() < 5.0, err.mean()
    # the scan is covered: no part of it is left far from the registered body
    assert report["scan_to_body_mm"]["mean"] < 5.0
    assert report["scan_to_body_mm"]["max"] < 30.0


def test_the_report_gives_the_scans_measurements(registered):
    from seamfit.body import body_measurements
    _, copy, _, report = registered
    m = body_measurements(copy)
    for key in ("height", "bust", "waist", "hip"):
        assert report["scan_measurements_cm"][key] == pytest.approx(m[key], abs=0.01)


def test_closest_points_are_exact():
    """The surface index against every triangle, on points near and far from the surface."""
    copy = decimated(load_body(SAMPLE))
    rng = np.random.default_rng(7)
    P = copy.vertices[rng.integers(0, copy.n_vertices, 300)] + rng.normal(0.0, 0.02, (300, 3))
    P = np.vstack([P, rng.uniform(-1.0, 2.0, (20, 3))])
    d, tri, Q, bary = SurfaceIndex(copy.vertices, copy.faces).query(P)
    F = copy.faces.astype(np.int64)
    A, B, C = copy.vertices[F[:, 0]], copy.vertices[F[:, 1]], copy.vertices[F[:, 2]]
    exact = np.array([np.linalg.norm(closest_on_triangles(np.repeat(P[i:i + 1], len(F), 0), A, B, C)[0] - P[i],
                                     axis=1).min() for i in range(len(P))])
    assert np.allclose(d, exact, rtol=0.0, atol=1e-12)
    assert np.allclose(np.einsum("ij,ijk->ik", bary, copy.vertices[F[tri]]), Q)
    assert np.allclose(np.linalg.norm(P - Q, axis=1), d)
    # within a bound: exact inside it, and beyond it exactly where the true distance is
    near, _, Q_near, _ = SurfaceIndex(copy.vertices, copy.faces).query(P, within=0.01)
    inside = exact <= 0.01
    assert 0 < inside.sum() < len(P)
    assert np.allclose(near[inside], exact[inside], rtol=0.0, atol=1e-12)
    assert np.all(near[~inside] > 0.01) and np.all(near >= exact - 1e-12)
    assert np.allclose(np.linalg.norm(P - Q_near, axis=1), near)


# ----------------------------------------------------------------------------- meshes that cannot be registered

@pytest.fixture(scope="module")
def sample():
    return load_body(SAMPLE)


def test_a_y_up_body_is_detected_and_the_fix_suggested(tmp_path, capsys, sample):
    # As Blender's OBJ importer lays a Z-up file down: (x, y, z) -> (x, -z, y).
    V = sample.vertices
    lying = save_body(Body(np.c_[V[:, 0], -V[:, 2], V[:, 1]], sample.faces), tmp_path / "yup.obj")
    code, _, err = cli(capsys, "body", "--register", lying, "--out", tmp_path / "b.obj")
    assert_one_line_error(code, err, str(lying), "wrong axes", "-Y-up", "rotate it -90 degrees about X", "Blender")
    assert not (tmp_path / "b.obj").exists()
    V2 = np.c_[V[:, 0], V[:, 2], -V[:, 1]]                  # head towards +Y
    with pytest.raises(RegistrationError, match=r"\+Y-up .* rotate it \+90 degrees about X"):
        check_registrable(Body(V2, sample.faces))


def test_a_body_facing_another_way_is_detected(sample):
    V = sample.vertices
    for turned, faces in (((-V[:, 0], -V[:, 1]), "+Y"), ((V[:, 1], -V[:, 0]), "-X"), ((-V[:, 1], V[:, 0]), "+X")):
        with pytest.raises(RegistrationError, match=rf"wrong axes: the body faces \{faces}"):
            check_registrable(Body(np.c_[turned[0], turned[1], V[:, 2]], sample.faces))


@pytest.mark.parametrize("scale, unit, fix", [(1000.0, "millimetres", "0.001"), (100.0, "centimetres", "0.01")])
def test_wrong_units_are_named_with_the_scale_that_fixes_them(tmp_path, capsys, sample, scale, unit, fix):
    path = save_body(Body(sample.vertices * scale, sample.faces), tmp_path / f"{unit}.obj")
    code, _, err = cli(capsys, "body", "--register", path, "--out", tmp_path / "b.obj")
    assert_one_line_error(code, err, str(path), "wrong units", unit, f"scale it by {fix}")


def test_a_body_with_holes_is_not_closed(tmp_path, capsys, sample):
    centres = sample.vertices[sample.faces].mean(axis=1)
    top = centres[:, 2] > centres[:, 2].max() - 0.01          # the crown cut off
    path = save_body(Body(sample.vertices, sample.faces[~top]), tmp_path / "open.obj")
    code, _, err = cli(capsys, "body", "--register", path, "--out", tmp_path / "b.obj")
    assert_one_line_error(code, err, str(path), "not closed", "boundary edges", "1 hole(s)", "Fill")


def _raise_arms(V: np.ndarray, degrees: float) -> np.ndarray:
    """Both arms turned up and out about the shoulders by ``degrees`` (a closed mesh of the
    same topology in another pose)."""
    lm = hm08_landmarks()
    out = V.copy()
    for side, sign in (("L", 1.0), ("R", -1.0)):
        S, E, W = (V[lm[f"{k}_{side}"]] for k in ("shoulder_point", "elbow", "wrist"))
        pivot = S + np.array([-sign * 0.03, 0.0, -0.05])
        u = (E - pivot) / np.linalg.norm(E - pivot)

        def seg(a, b):
            ab = b - a
            h = np.clip((V - a) @ ab / (ab @ ab), 0.0, 1.0)
            return np.linalg.norm(V - a - h[:, None] * ab, axis=1)

        near = np.minimum.reduce([seg(pivot, E) / 0.07, seg(E, W) / 0.07, seg(W, W + 0.6 * (W - E)) / 0.1])
        w = np.clip(((V - pivot) @ u + 0.02) / 0.06, 0.0, 1.0) * (near < 1) * (sign * V[:, 0] > 0)
        a = sign * np.radians(degrees) * w
        d = out - pivot
        out[:, 0] = pivot[0] + np.cos(a) * d[:, 0] - np.sin(a) * d[:, 2]
        out[:, 2] = pivot[2] + np.sin(a) * d[:, 0] + np.cos(a) * d[:, 2]
    return out


def test_arms_raised_to_a_t_pose_are_another_pose(tmp_path, capsys, sample):
    path = save_body(Body(_raise_arms(sample.vertices, 50.0), sample.faces), tmp_path / "tpose.obj")
    with pytest.raises(RegistrationError, match="another pose"):
        check_registrable(load_body(path))                  # the first, cheap checks
    code, _, err = cli(capsys, "body", "--register", path, "--out", tmp_path / "b.obj")
    assert_one_line_error(code, err, str(path), "another pose", "arms raised", "A-pose")


def test_arms_raised_a_little_are_another_pose_before_the_surface_fit(tmp_path, capsys, sample, monkeypatch):
    import seamfit.body.register as register

    def never(*args, **kwargs):
        raise AssertionError("the surface fit ran")

    monkeypatch.setattr(register, "_surface_fit", never)
    path = save_body(Body(_raise_arms(sample.vertices, 25.0), sample.faces), tmp_path / "arms.obj")
    check_registrable(load_body(path))                      # as wide as an A-pose: the shape fit tells
    code, _, err = cli(capsys, "body", "--register", path, "--out", tmp_path / "b.obj", "-q")
    assert_one_line_error(code, err, str(path), "another pose", "cm from the template", "A-pose")


def test_arms_lowered_are_another_pose_before_any_fitting(tmp_path, capsys, sample, monkeypatch):
    import seamfit.body.register as register

    def never(*args, **kwargs):
        raise AssertionError("the fitting ran")

    monkeypatch.setattr(register, "_model_fit", never)
    path = save_body(Body(_raise_arms(sample.vertices, -30.0), sample.faces), tmp_path / "arms_down.obj")
    code, _, err = cli(capsys, "body", "--register", path, "--out", tmp_path / "b.obj")
    assert_one_line_error(code, err, str(path), "another pose", "arms lowered", "A-pose",
                          "arms hanging about 40 degrees")
    assert not (tmp_path / "b.obj").exists()


def test_the_sample_bodies_pass_the_checks():
    for path in sorted(BODIES.glob("*.obj")):
        check_registrable(load_body(path))


# ----------------------------------------------------------------------------- grade

def test_grade_registers_a_target_of_another_mesh(tmp_path, capsys):
    """End to end at the coarse settings of the other grade tests: a decimated size 10."""
    target = save_body(decimated(load_body(BODIES / "women_size10.obj")), tmp_path / "size10_scan.obj")
    out = tmp_path / "out"
    code, _, err = cli(capsys, "grade", SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json",
                       "--base-body", BASE, "--target-body", target, "--out", out,
                       "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "2", "--no-picture")
    assert code == 0, err
    line = next(line for line in err.splitlines() if "registered:" in line)
    assert "mm mean" in line and "mm max" in line and "registering the base body's mesh onto it" in err
    report = json.loads((out / "report.json").read_text())
    reg = report["registration"]
    assert reg["scan"] == str(target) and 0.0 < reg["error_mm"]["mean"] < 5.0
    assert reg["error_mm"]["mean"] <= reg["error_mm"]["max"] < 30.0
    assert f"{reg['error_mm']['mean']:.1f} mm mean, {reg['error_mm']['max']:.1f} mm max" in line
    assert reg["n_vertices"] == load_body(BASE).n_vertices
    assert report["inputs"]["target_body"] == str(target)
    assert (out / "pattern.json").is_file() and (out / "garment.obj").is_file()


def _lying(V):
    return np.c_[V[:, 0], -V[:, 2], V[:, 1]]          # as Blender's OBJ importer lays a Z-up file down


@pytest.mark.parametrize("case, words", [
    ("the base body's mesh, Y-up", ("wrong axes", "-Y-up", "rotate it -90 degrees about X", "Blender")),
    ("another mesh, Y-up", ("wrong axes", "-Y-up", "rotate it -90 degrees about X")),
    ("another mesh, in millimetres", ("millimetres", "scale it by 0.001")),
    ("another mesh, in centimetres", ("centimetres", "scale it by 0.01")),
    ("another mesh, arms lowered", ("another pose", "arms lowered", "A-pose")),
])
def test_grade_refuses_a_target_it_cannot_use_before_any_work(tmp_path, capsys, monkeypatch, case, words):
    """One line naming the file, the reason and the fix, before any registration, SDF or drape."""
    import seamfit.body.register as register
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(register, "register_body", lambda *a, **k: pytest.fail("registration started"))
    body = load_body(BODIES / "women_size10.obj")
    V = body.vertices
    V = {"Y-up": _lying(V), "millimetres": 1000.0 * V, "centimetres": 100.0 * V,
         "arms lowered": _raise_arms(V, -30.0)}[case.split(", ")[1].replace("in ", "")]
    faces = body.faces if case.startswith("the base") else body.faces[::-1].copy()   # faces reordered: another mesh
    target = save_body(Body(V, faces), tmp_path / "target.obj")
    code, _, err = cli(capsys, "grade", SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json", "--base-body", BASE,
                       "--target-body", target, "--out", tmp_path / "out", "--no-picture")
    assert code == 2, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("seamfit grade: error: ")]
    assert len(errors) == 1 and str(target) in errors[0], err
    assert all(line.startswith("seamfit grade: ") for line in err.splitlines() if line.strip()), err
    for w in words:
        assert w in errors[0], (w, errors[0])
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()
