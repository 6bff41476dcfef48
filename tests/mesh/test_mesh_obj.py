"""OBJ out and back, and the ``seamfit mesh`` command."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from seamfit.mesh import build_sewn_mesh, read_obj, read_obj_positions, write_obj
from seamfit.mesh.obj import obj_header
from seamfit.pattern import load_pattern
from common import SAMPLES, command_runner

PATTERNS = SAMPLES / "patterns"
CIRCLE = PATTERNS / "gc_circle_skirt/size06/pattern.json"
BODICE = PATTERNS / "fs_bodice/size06/pattern.json"


@pytest.fixture(scope="module")
def mesh():
    return build_sewn_mesh(load_pattern(BODICE), 2.0)


def test_obj_round_trip(mesh, tmp_path):
    path = write_obj(tmp_path / "m.obj", mesh)
    data = read_obj(path)
    scale = np.abs(mesh.x0).max()
    assert np.abs(data.positions - mesh.x0).max() <= 1e-9 * scale
    assert np.array_equal(read_obj_positions(path), data.positions)
    assert np.array_equal(data.faces, mesh.triangles)
    assert np.array_equal(data.face_uv, mesh.triangles)          # vt index = v index
    assert np.abs(data.uv - mesh.uv_cm).max() <= 1e-9 * np.abs(mesh.uv_cm).max()
    assert [g[0] for g in data.groups] == mesh.panel_names
    for k, (name, first, end) in enumerate(data.groups):
        assert np.array_equal(data.faces[first:end], mesh.triangles[mesh.triangle_panel == k])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.obj"]    # no temporary left


def test_obj_custom_positions_and_replace(mesh, tmp_path):
    path = tmp_path / "m.obj"
    write_obj(path, mesh)
    moved = mesh.x0 * 1.5 + np.array([0.1, -0.2, 0.3])
    write_obj(path, mesh, positions=moved)
    back = read_obj_positions(path)
    assert np.abs(back - moved).max() <= 1e-9 * np.abs(moved).max()
    with pytest.raises(ValueError):
        write_obj(path, mesh, positions=moved[:-1])
    bad = moved.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError):
        write_obj(path, mesh, positions=bad)
    assert np.array_equal(read_obj_positions(path), back)             # failed writes left it whole


def _savetxt_obj(mesh, x) -> str:
    """The file as written with np.savetxt row by row, before the rows were formatted in
    one call: the writer must still produce these exact bytes."""
    import io
    out = io.StringIO()
    out.write(obj_header(mesh))
    np.savetxt(out, x, fmt="v %.17g %.17g %.17g")
    np.savetxt(out, mesh.uv_cm, fmt="vt %.17g %.17g")
    for k, name in enumerate(mesh.panel_names):
        out.write(f"g {name}\n")
        tri = mesh.triangles[mesh.triangle_panel == k].astype(np.int64) + 1
        np.savetxt(out, np.repeat(tri, 2, axis=1), fmt="f %d/%d %d/%d %d/%d")
    return out.getvalue()


def test_obj_bytes_match_row_by_row_formatting(mesh, tmp_path):
    rng = np.random.default_rng(3)
    moved = mesh.x0 + rng.normal(scale=1e-3, size=mesh.x0.shape)    # full 17-digit values
    moved[0] = [0.0, -0.0, 1e-300]
    moved[1] = [-1.5, 123456.789, 5e-7]
    text = write_obj(tmp_path / "m.obj", mesh, positions=moved).read_text()
    assert text == _savetxt_obj(mesh, moved)
    assert text.count("\nf ") == len(mesh.triangles)
    assert text.endswith("\n")


@pytest.fixture
def run(monkeypatch, capsys):
    return command_runner(monkeypatch, capsys, "mesh")


def test_mesh_command_writes_obj_svg_report(run, tmp_path):
    out = tmp_path / "out"
    code, stdout, err = run(CIRCLE, "--out", out, "--edge-length", "2.5")
    assert code == 0 and err == ""
    assert sorted(p.name for p in out.iterdir()) == ["mesh.obj", "pattern.svg", "report.json"]
    report = json.loads((out / "report.json").read_text())
    mesh = build_sewn_mesh(load_pattern(CIRCLE), 2.5)
    st = mesh.stats()
    for key in ("vertices", "triangles", "stitches", "sewing_pairs", "boundary_vertices"):
        assert report[key] == st[key], key
    assert report["edge_length_cm"] == 2.5
    assert report["max_seam_count_mismatch"] == 0
    assert report["min_angle_deg"] == pytest.approx(st["min_angle_deg"])
    assert report["min_angle_interior_deg"] == pytest.approx(st["min_angle_interior_deg"])
    assert report["area_error"] == pytest.approx(st["area_error"])
    assert report["cache_key"] == mesh.cache_key()
    assert report["seconds"]["total"] > 0
    assert sum(p["triangles"] for p in report["per_panel"]) == st["triangles"]
    data = read_obj(out / "mesh.obj")
    assert np.abs(data.positions - mesh.x0).max() <= 1e-9 * np.abs(mesh.x0).max()
    assert np.array_equal(data.faces, mesh.triangles)
    root = ET.parse(out / "pattern.svg").getroot()
    assert root.tag.endswith("svg") and root.get("width").endswith("cm")
    assert f"{st['vertices']} vertices" in stdout


def test_mesh_command_errors(run, tmp_path):
    code, _, err = run(tmp_path / "missing.json", "--out", tmp_path / "o")
    assert code == 2 and "missing.json" in err and "Traceback" not in err
    code, _, err = run(CIRCLE, "--out", tmp_path / "o", "--edge-length", "-1")
    assert code == 2 and "--edge-length" in err
    assert not (tmp_path / "o").exists()
    bad = json.loads(CIRCLE.read_text())
    bad["stitches"][2]["b"]["panel"] = "no_such_panel"
    src = tmp_path / "bad.json"
    src.write_text(json.dumps(bad))
    code, _, err = run(src, "--out", tmp_path / "o")
    assert code == 2 and "stitch 2" in err and "no_such_panel" in err and str(src) in err
    assert not (tmp_path / "o").exists()
