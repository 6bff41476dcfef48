"""Curves, GarmentCode import, format detection and saving, on the repository's sample files."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import curves, load_pattern, read_garmentcode, save_pattern
from seamfit.pattern.garmentcode import GC_TO_WORLD, euler_xyz_deg_to_matrix, pattern_from_garmentcode
from seamfit.pattern.model import Edge, range_indices
from seamfit.pattern.sewpat import pattern_to_dict
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
SEWPAT_FILES = sorted(PATTERNS.glob("*/*/pattern.json"))
GC_SPECS = sorted(PATTERNS.glob("*/*/native/*_specification.json"))


def _rel(p: Path) -> str:
    return str(p.relative_to(PATTERNS))


def test_samples_present():
    assert len(SEWPAT_FILES) >= 6 and len(GC_SPECS) >= 2


# ----------------------------------------------------------------------------- curves

@pytest.mark.parametrize("path", SEWPAT_FILES, ids=_rel)
def test_edge_curves_pass_through_outline_samples(path):
    """Outlines are samples of the edge curves at <= 1 cm arc-length spacing: the curve
    passes through every sample of its range, its length is length_cm, and re-sampling the
    curve by arc length gives the same points (deviations are the files' 1e-4 cm rounding;
    measured <= 3.4e-4 cm)."""
    pattern = load_pattern(path)
    kinds = set()
    for panel in pattern.panels:
        for e in panel.edges:
            kinds.add(e.kind)
            pts = panel.outline_cm[range_indices((e.start, e.end), panel.n_vertices)]
            where = f"{panel.name} edge {e.id} ({e.kind})"
            assert curves.distance_to_curve(e, pts).max() < 1e-3, where
            assert curves.length(e) == pytest.approx(e.length_cm, abs=1e-3), where
            resampled = curves.sample_by_length(e, 1.0)
            assert resampled.shape == pts.shape, where
            assert np.abs(resampled - pts).max() < 1e-3, where
    assert kinds  # every file has edges


def test_curve_kinds_seen_in_samples():
    kinds = {e.kind for p in SEWPAT_FILES for pn in load_pattern(p).panels for e in pn.edges}
    assert {"line", "quadratic", "cubic", "arc"} <= kinds


def test_line_and_arc_exact():
    line = Edge(id=0, start=0, end=1, kind="line", p0=(1.0, 2.0), p1=(4.0, 6.0))
    assert curves.length(line) == pytest.approx(5.0)
    assert np.allclose(curves.evaluate(line, [0, 0.5, 1]), [[1, 2], [2.5, 4], [4, 6]])
    # quarter circle, radius 10, counter-clockwise from angle 0 to pi/2
    arc = Edge(id=0, start=0, end=1, kind="arc", p0=(13.0, 5.0), p1=(3.0, 15.0),
               arc={"center": [3.0, 5.0], "radius": 10.0, "angle0_rad": 0.0, "angle1_rad": math.pi / 2})
    assert curves.length(arc) == pytest.approx(5 * math.pi)
    assert np.allclose(curves.evaluate(arc, [0.5]), [[3 + 10 / math.sqrt(2), 5 + 10 / math.sqrt(2)]])
    t0, t1 = curves.end_tangents(arc)
    assert np.allclose(t0, [0, 1]) and np.allclose(t1, [-1, 0])


def test_bezier_length_and_arc_length_sampling():
    # a parabola y = x^2 on [0, 1] as a quadratic Bezier: closed-form length
    quad = Edge(id=0, start=0, end=1, kind="quadratic", p0=(0.0, 0.0), p1=(1.0, 1.0), ctrl=[(0.5, 0.0)])
    exact = 0.5 * math.sqrt(5) + 0.25 * math.asinh(2)
    assert curves.length(quad) == pytest.approx(exact, rel=1e-10)
    # scaled to 40 cm and sampled at <= 1 cm: equal chord lengths, ends exact
    big = Edge(id=0, start=0, end=1, kind="cubic", p0=(0.0, 0.0), p1=(40.0, 0.0),
               ctrl=[(0.0, 30.0), (40.0, 30.0)])
    length = curves.length(big)
    pts = curves.sample_by_length(big, 1.0)
    assert len(pts) - 1 == math.ceil(length)
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert chords.max() <= 1.0 and chords.max() - chords.min() < 2e-3
    assert np.allclose(pts[[0, -1]], [big.p0, big.p1])
    s = np.linspace(0, length, 7)
    t = curves.parameters_at_lengths(big, s)
    # S(t) from an independent dense polyline
    dense = curves.evaluate(big, np.linspace(0, 1, 200001))
    cum = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    assert np.allclose(np.interp(t, np.linspace(0, 1, 200001), cum), s, atol=1e-5)


def test_degenerate_control_point_tangent():
    # first control point on p0: the start tangent comes from the next control point
    e = Edge(id=0, start=0, end=1, kind="cubic", p0=(0.0, 0.0), p1=(10.0, 0.0), ctrl=[(0.0, 0.0), (0.0, 5.0)])
    t0, t1 = curves.end_tangents(e)
    assert np.allclose(t0, [0, 1])
    assert np.allclose(t1, np.array([10, -5]) / math.hypot(10, 5))


def test_curve_errors_name_edge():
    bad = Edge(id=3, start=0, end=1, kind="cubic", p0=(0.0, 0.0), p1=(1.0, 0.0), ctrl=[(0.5, 1.0)])
    with pytest.raises(PatternError, match=r"edge 3 \(cubic\).*2 control"):
        curves.length(bad)


# ----------------------------------------------------------------------------- GarmentCode

@pytest.mark.parametrize("spec", GC_SPECS, ids=_rel)
def test_garmentcode_matches_sewpat(spec):
    """Reading GarmentCode's own file gives the pattern the sewpat-1 file beside it holds."""
    g = read_garmentcode(spec)
    ref = load_pattern(spec.parent.parent / "pattern.json")
    assert g.garment_id == ref.garment_id
    assert [p.name for p in g.panels] == [p.name for p in ref.panels]
    for a, b in zip(g.panels, ref.panels):
        assert [e.kind for e in a.edges] == [e.kind for e in b.edges], a.name
        assert [e.label for e in a.edges] == [e.label for e in b.edges], a.name
        for ea, eb in zip(a.edges, b.edges):
            assert ea.length_cm == pytest.approx(eb.length_cm, abs=0.1), (a.name, ea.id)  # 1 mm
            assert (ea.start, ea.end) == (eb.start, eb.end), (a.name, ea.id)
        assert a.signed_area_cm2() == pytest.approx(b.signed_area_cm2(), rel=0.005), a.name
        assert a.n_vertices == b.n_vertices
        assert np.abs(a.outline_cm - b.outline_cm).max() < 1e-3, a.name
        assert (a.nodes, a.corners, a.landmarks, a.orientation) == (b.nodes, b.corners, b.landmarks, b.orientation)
        # placement: same rotation; translation differs only by the body-alignment shift
        pa, pb = a.placement, b.placement
        assert pa.kind == "exact" and pa.side == pb.side
        assert np.allclose(pa.rotation, pb.rotation, atol=1e-7)
        dy = pb.extra["body_alignment_dy_m"]
        assert np.allclose(pa.translation_m + [0, dy, 0], pb.translation_m, atol=1e-6), a.name
        assert np.allclose(pa.extra["rotation_quat_xyzw"], pb.extra["rotation_quat_xyzw"], atol=1e-7)
    assert len(g.stitches) == len(ref.stitches)
    for k, (sa, sb) in enumerate(zip(g.stitches, ref.stitches)):
        assert (sa.kind, sa.orientation, sa.gathered) == (sb.kind, sb.orientation, sb.gathered), k
        for x, y in ((sa.a, sb.a), (sa.b, sb.b)):
            assert (x.panel, x.range, x.edge, x.landmarks) == (y.panel, y.range, y.edge, y.landmarks), k
        assert sa.length_a_cm == pytest.approx(sb.length_a_cm, abs=1e-3)
        assert sa.length_b_cm == pytest.approx(sb.length_b_cm, abs=1e-3)
    assert any(s.gathered for s in g.stitches)


def _square_spec(curvature=None, rotation=(0, 0, 0), units_in_meter=100, translation=(1.0, 2.0, 3.0)):
    s = 10.0 * units_in_meter / 100       # a 10 cm square in file units
    edge0 = {"endpoints": [0, 1]}
    if curvature is not None:
        edge0["curvature"] = curvature
    return {"pattern": {"panels": {"sq": {
        "translation": list(translation), "rotation": list(rotation),
        "vertices": [[0, 0], [s, 0], [s, s], [0, s]],
        "edges": [edge0, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]}},
        "stitches": []}, "properties": {"units_in_meter": units_in_meter, "curvature_coords": "relative"}}


@pytest.mark.parametrize("large_arc", [0, 1])
@pytest.mark.parametrize("right", [0, 1])
def test_garmentcode_circle_flags(large_arc, right):
    """GarmentCode circle edges: ``right`` bulges right of the chord (runs ccw), ``large_arc``
    takes the longer way round."""
    p = pattern_from_garmentcode(_square_spec({"type": "circle", "params": [6.0, large_arc, right]}), "sq.json")
    e = p.panels[0].edges[0]
    assert e.kind == "arc"
    c, r, a0, a1 = curves.arc_params(e)
    assert r == 6.0
    assert np.allclose(curves.evaluate(e, [0.0, 1.0]), [e.p0, e.p1], atol=1e-9)
    sweep = a1 - a0
    assert (sweep > 0) == bool(right)
    assert (abs(sweep) > math.pi) == bool(large_arc)
    mid = curves.evaluate(e, [0.5])[0]
    assert (mid[1] < 0) == bool(right)          # chord runs along +u; its right is -v


def test_garmentcode_relative_bezier_and_rotation():
    p = pattern_from_garmentcode(
        _square_spec({"type": "cubic", "params": [[0.25, 0.5], [0.75, -0.5]]}, rotation=(0, 0, 90)), "sq.json")
    e = p.panels[0].edges[0]
    # x along the chord (0..1), y along the chord turned +90 deg, in chord lengths (10 cm)
    assert np.allclose(e.ctrl, [(2.5, 5.0), (7.5, -5.0)])
    pl = p.panels[0].placement
    rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(euler_xyz_deg_to_matrix([0, 0, 90]), rz)
    assert np.allclose(pl.rotation, GC_TO_WORLD @ rz)
    assert np.allclose(pl.translation_m, [0.01, -0.03, 0.02])   # [x, -z, y] / 100
    assert pl.side == "front"


def test_garmentcode_units_in_meter():
    # a millimetre file (units_in_meter = 1000) reads in cm
    p = pattern_from_garmentcode(_square_spec(units_in_meter=1000, translation=(10.0, 20.0, -30.0)), "sq.json")
    o = p.panels[0].outline_cm
    assert np.allclose(o.max(axis=0) - o.min(axis=0), [10.0, 10.0])
    assert np.allclose(p.panels[0].placement.translation_m, [0.01, 0.03, 0.02])
    assert p.panels[0].placement.side == "back"


def test_garmentcode_errors_name_file_panel_edge(tmp_path):
    spec = _square_spec({"type": "spline", "params": []})
    with pytest.raises(PatternError, match=r"x_specification\.json: panel 'sq' edge 0: unsupported curvature type 'spline'"):
        pattern_from_garmentcode(spec, "x_specification.json")
    spec = _square_spec()
    spec["pattern"]["panels"]["sq"]["edges"][2]["endpoints"] = [3, 2]
    with pytest.raises(PatternError, match=r"panel 'sq' edge 2: starts at vertex 3 but edge 1 ends at vertex 2"):
        pattern_from_garmentcode(spec, "x.json")
    spec = _square_spec()
    spec["pattern"]["stitches"] = [[{"panel": "sq", "edge": 0}, {"panel": "sq", "edge": 7}]]
    with pytest.raises(PatternError, match=r"stitch 0 side b: panel 'sq' has no edge 7"):
        pattern_from_garmentcode(spec, "x.json")
    spec["pattern"]["stitches"] = [[{"panel": "nope", "edge": 0}, {"panel": "sq", "edge": 1}]]
    with pytest.raises(PatternError, match=r"stitch 0 side a: unknown panel 'nope'"):
        pattern_from_garmentcode(spec, "x.json")
    spec = _square_spec({"type": "circle", "params": [2.0, 0, 1]})   # radius < half the 10 cm chord
    with pytest.raises(PatternError, match=r"panel 'sq' edge 0: circle radius 2 cm is shorter"):
        pattern_from_garmentcode(spec, "x.json")


# ----------------------------------------------------------------------------- load / save

def test_load_pattern_detects_format():
    sew = load_pattern(PATTERNS / "gc_pencil_skirt/size06/pattern.json")
    gc = load_pattern(PATTERNS / "gc_pencil_skirt/size06/native/gc_pencil_skirt_specification.json")
    assert sew.body_id == "size06" and "format" not in sew.extra
    assert gc.extra["source"]["system"] == "GarmentCode"
    assert gc.garment_id == "gc_pencil_skirt"
    assert [p.name for p in gc.panels] == [p.name for p in sew.panels]


@pytest.mark.parametrize("name, content, message", [
    ("missing.json", None, r"missing\.json: no such file"),
    ("broken.json", '{"format": "sewpat-1", ', r"broken\.json: invalid JSON at line 1"),
    ("other.json", '{"hello": 1}', r"other\.json: JSON file is not a pattern"),
    ("future.json", '{"format": "sewpat-9"}', r"future\.json: unsupported pattern format 'sewpat-9'"),
    ("drawing.dwg", "0\nSECTION\n", r"drawing\.dwg: unsupported file type '\.dwg'"),
    ("list.json", "[1, 2]", r"list\.json: JSON file is not a pattern"),
])
def test_load_pattern_errors_name_file(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(PatternError, match=message):
        load_pattern(path)


def test_load_pattern_rejects_directory(tmp_path):
    with pytest.raises(PatternError, match="is a directory"):
        load_pattern(tmp_path)


def test_save_garmentcode_as_sewpat_roundtrip(tmp_path):
    gc = load_pattern(PATTERNS / "gc_circle_skirt/size06/native/gc_circle_skirt_specification.json")
    out = save_pattern(gc, tmp_path / "converted.json")
    back = load_pattern(out)
    assert json.loads(out.read_text())["format"] == "sewpat-1"
    d0, d1 = pattern_to_dict(gc), pattern_to_dict(back)
    assert d0 == d1
    assert sorted(x.name for x in tmp_path.iterdir()) == ["converted.json"]   # no temporary left


def test_save_refuses_to_overwrite_input(tmp_path):
    src = tmp_path / "pattern.json"
    src.write_bytes((PATTERNS / "fs_bodice/size06/pattern.json").read_bytes())
    before = src.read_bytes()
    p = load_pattern(src)
    with pytest.raises(PatternError, match=r"pattern\.json: is the file this pattern was read from"):
        save_pattern(p, src)
    with pytest.raises(PatternError, match="is the file this pattern was read from"):
        save_pattern(p, tmp_path / "." / "pattern.json")      # same file, other spelling
    assert src.read_bytes() == before
    p.panels[0].outline_cm = p.panels[0].outline_cm + 0.5
    save_pattern(p, src, overwrite=True)
    assert np.allclose(load_pattern(src).panels[0].outline_cm, p.panels[0].outline_cm)
