"""Body mesh reading and writing: OBJ and PLY, round trips and every bad input."""
from __future__ import annotations

import time

import numpy as np
import pytest

from seamfit.body import Body, load_body, save_body
from seamfit.errors import BodyError
from common import SAMPLES

BODIES = SAMPLES / "bodies"

OBJ_TEXT = """# a hand-written mesh
mtllib none.mtl
o thing
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0 1.0
vt 0 0
vt 1 0
vn 0 0 1
g group
usemtl skin
s off
f 1 2 3
f 1/1 3/2 4/1
  f 1//1 2//1 4//1
f 1/1/1 2/2/1 3/1/1 4/2/1
v 0.5 0.5 1
f -1 -4 -3
f 5 1 2 3 4
l 1 2
"""


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return p


def test_obj_all_face_forms(tmp_path):
    b = load_body(write(tmp_path, "m.obj", OBJ_TEXT))
    assert b.vertices.dtype == np.float64 and b.faces.dtype == np.int32
    np.testing.assert_array_equal(b.vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]])
    expected = [[0, 1, 2], [0, 2, 3], [0, 1, 3],
                [0, 1, 2], [0, 2, 3],          # quad, fan-triangulated
                [4, 1, 2],                     # negative indices: -1 is the last vertex so far
                [4, 0, 1], [4, 1, 2], [4, 2, 3]]  # pentagon
    np.testing.assert_array_equal(b.faces, expected)
    assert b.name == "m" and b.source_file == str(tmp_path / "m.obj")


def test_obj_crlf_and_continuation(tmp_path):
    text = "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 \\\r\n 2 3\r\n"
    b = load_body(write(tmp_path, "crlf.obj", text))
    np.testing.assert_array_equal(b.faces, [[0, 1, 2]])


@pytest.mark.parametrize("text, match", [
    ("v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n", "line 3: bad vertex"),
    ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "line 2: vertex needs 3 coordinates"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: face needs at least 3 vertices"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: face refers to vertex 0"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: face refers to vertex 4.*3 vertices"),
    ("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", "line 3: face refers to vertex -3"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 a\n", "line 5: bad face vertex index"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 /2 3\n", "line 4: face vertex without an index"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"),
])
def test_obj_errors_name_file_and_line(tmp_path, text, match):
    p = write(tmp_path, "bad.obj", text)
    with pytest.raises(BodyError, match=match) as exc:
        load_body(p)
    assert str(p) in str(exc.value)


def test_missing_directory_and_unknown_format(tmp_path):
    with pytest.raises(BodyError, match="no such body file"):
        load_body(tmp_path / "missing.obj")
    with pytest.raises(BodyError, match="is a directory"):
        load_body(tmp_path)
    with pytest.raises(BodyError, match="unsupported body format '.stl'"):
        load_body(write(tmp_path, "x.stl", "solid x"))
    with pytest.raises(BodyError, match="unsupported"):
        save_body(Body(np.zeros((3, 3)), [[0, 1, 2]]), tmp_path / "x.stl")


PLY_VERTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.25]])


def ply_header(fmt, n_faces=2, extra=""):
    return (f"ply\nformat {fmt} 1.0\ncomment made by hand\nelement vertex 4\nproperty float x\nproperty float y\n"
            f"property float z\nproperty uchar red\n{extra}element face {n_faces}\n"
            f"property list uchar int vertex_indices\nproperty int flags\nend_header\n")


def test_ply_ascii_with_quad_and_extra_properties(tmp_path):
    body = "\n".join(f"{x} {y} {z} 255" for x, y, z in PLY_VERTS) + "\n3 0 1 2 7\n4 0 1 2 3 9\n"
    b = load_body(write(tmp_path, "a.ply", ply_header("ascii") + body))
    np.testing.assert_allclose(b.vertices, PLY_VERTS)
    np.testing.assert_array_equal(b.faces, [[0, 1, 2], [0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("endian, fmt", [("<", "binary_little_endian"), (">", "binary_big_endian")])
def test_ply_binary_both_endians(tmp_path, endian, fmt):
    extra = "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
    hdr = ply_header(fmt, extra=extra).replace("element face 2", "element face 2")
    # elements in header order: vertex, edge, face
    vert = np.zeros(4, dtype=[("x", endian + "f4"), ("y", endian + "f4"), ("z", endian + "f4"), ("r", "u1")])
    vert["x"], vert["y"], vert["z"] = PLY_VERTS.T
    edge = np.array([(0, 1)], dtype=[("a", endian + "i4"), ("b", endian + "i4")])
    f1 = np.array([(3, (0, 1, 2), 1)], dtype=[("n", "u1"), ("i", endian + "i4", 3), ("f", endian + "i4")])
    f2 = np.array([(4, (0, 1, 2, 3), 2)], dtype=[("n", "u1"), ("i", endian + "i4", 4), ("f", endian + "i4")])
    data = hdr.encode() + vert.tobytes() + edge.tobytes() + f1.tobytes() + f2.tobytes()
    b = load_body(write(tmp_path, "b.ply", data))
    np.testing.assert_allclose(b.vertices, PLY_VERTS)
    np.testing.assert_array_equal(b.faces, [[0, 1, 2], [0, 1, 2], [0, 2, 3]])
    # all-triangle fast path
    tri = np.array([(3, (0, 1, 2), 1), (3, (0, 2, 3), 2)], dtype=[("n", "u1"), ("i", endian + "i4", 3),
                                                                   ("f", endian + "i4")])
    data = hdr.encode() + vert.tobytes() + edge.tobytes() + tri.tobytes()
    np.testing.assert_array_equal(load_body(write(tmp_path, "c.ply", data)).faces, [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(BodyError, match="truncated in element 'face'"):
        load_body(write(tmp_path, "t.ply", data[:-5]))


@pytest.mark.parametrize("text, match", [
    ("plyx", "not a PLY file"),
    ("ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n", "unsupported PLY format"),
    ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
     "no 'z' property"),
    ("ply\nformat ascii 1.0\nelement face 1\nend_header\n", "no 'vertex' element"),
    ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty blah y\nend_header\n",
     "header line 5.*unknown property type"),
    (ply_header("ascii", 1) + "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n3 0 1 9 0\n", "face 0 refers to vertex 9"),
    (ply_header("ascii", 1) + "0 0 0 1\n1 0 0 1\n1 q 0 1\n0 1 0 1\n3 0 1 2 0\n", "PLY line 15: bad 'vertex' row"),
    (ply_header("ascii", 1) + "0 0 0 1\n1 0 0 1\n", "ends early in element 'vertex'"),
    (ply_header("ascii", 1) + "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n2 0 1 0\n", "face 0 has 2 vertices"),
    (ply_header("ascii", 2) + "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n3 0 1 2 0\n3 0 x 2 0\n",
     "PLY line 18: bad 'face' row"),
])
def test_ply_errors(tmp_path, text, match):
    p = write(tmp_path, "bad.ply", text)
    with pytest.raises(BodyError, match=match) as exc:
        load_body(p)
    assert str(p) in str(exc.value)


@pytest.mark.parametrize("name, kw", [("r.obj", {}), ("r.ply", {}), ("ra.ply", {"binary": False})])
def test_round_trip_of_sample_body_is_exact(tmp_path, name, kw):
    b = load_body(BODIES / "women_size06.obj")
    path = save_body(b, tmp_path / name, **kw)
    c = load_body(path)
    assert np.array_equal(c.vertices, b.vertices) and np.array_equal(c.faces, b.faces)
    assert not list(tmp_path.glob(".*.tmp"))  # written atomically


def test_sample_body_loads_fast():
    best = min(_timed_load() for _ in range(3))
    assert best < 0.3, best


def _timed_load():
    t0 = time.perf_counter()
    b = load_body(BODIES / "women_size10.obj")
    dt = time.perf_counter() - t0
    assert b.n_vertices == 13380 and b.n_faces == 26756
    return dt


def test_body_checks_shapes():
    with pytest.raises(BodyError, match="vertices must have shape"):
        Body(np.zeros((3, 2)), [[0, 1, 2]], name="flat")
    with pytest.raises(BodyError, match="faces must have shape"):
        Body(np.zeros((3, 3)), [[0, 1, 2, 3]], name="quad")
