"""Notches, grain lines, internal lines and drill holes carried through grading, and
symmetric bases graded symmetric: the pencil skirt, marked up, graded to size 10 at a
coarse setting; the carrying map checked exactly on an affine move; left/right pairs."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from seamfit.cli import main
from seamfit.mesh import build_sewn_mesh, outline_from_uv
from seamfit.pattern import load_pattern, save_pattern
from seamfit.pattern.curves import evaluate
from seamfit.pattern.markings import carry_markings, map_points
from seamfit.pattern.model import range_indices
from seamfit.pattern.refit import refit_pattern
from seamfit.pattern.symmetry import find_symmetries, symmetrize, symmetry_error_cm
from common import SAMPLES, SHARED_DATA

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
SHARED = SHARED_DATA


def _marked(base):
    """Notches at the middle of every stitch side, a grain line, an internal line from the
    top edge down into the panel (a dart's leg) and a drill hole at its end."""
    marked = copy.deepcopy(base)
    for pn in marked.panels:
        n = pn.n_vertices
        mids = sorted({(s.range[0] + ((s.range[1] - s.range[0]) % n) // 2) % n
                       for st in marked.stitches for s in (st.a, st.b) if s.panel == pn.name})
        pn.extra["notches"] = [{"vertex": v, "type": "slit", "depth_cm": 0.6} for v in mids]
        o = pn.outline_cm
        lo, hi = o.min(axis=0), o.max(axis=0)
        cu = float(lo[0] + hi[0]) / 2
        pn.extra["grain_line_cm"] = [[cu, float(lo[1]) + 1.0], [cu, float(hi[1]) - 1.0]]
        top = int(np.argmax(o[:, 1] - 1e-3 * np.abs(o[:, 0] - cu)))   # the top vertex nearest the centre
        start = o[top]
        end = start + np.array([0.0, -min(8.0, 0.4 * float(hi[1] - lo[1]))])
        pn.extra["internal_lines"] = [{"points_cm": [start.tolist(), end.tolist()], "closed": False}]
        pn.extra["drill_holes_cm"] = [end.tolist()]
    return marked


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("markings")
    src = tmp / "marked.json"
    save_pattern(_marked(load_pattern(PATTERN)), src)
    out = tmp / "graded"
    assert main(["grade", str(src), "--base-body", str(B0), "--target-body", str(B1), "--out", str(out),
                 "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "2",
                 "--checkpoint-every", "1", "--no-picture", "-q"]) == 0
    return load_pattern(src), load_pattern(out / "pattern.json"), json.loads((out / "report.json").read_text())


def _dist_to_polyline(p, o):
    a, b = o, np.roll(o, -1, axis=0)
    e = b - a
    t = np.clip(((p - a) * e).sum(axis=1) / np.maximum((e * e).sum(axis=1), 1e-18), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * e - p, axis=1).min())


def test_notches_stay_on_their_edge(graded):
    base, res, rep = graded
    n_notches = 0
    for pb, pg in zip(base.panels, res.panels):
        assert [x["vertex"] for x in pg.extra["notches"]] == [x["vertex"] for x in pb.extra["notches"]]
        for notch in pg.extra["notches"]:
            v = notch["vertex"]
            edge = next(e for e in pg.edges if v in range_indices((e.start, e.end), pg.n_vertices))
            ts = np.linspace(0, 1, 2001)
            curve = np.asarray(evaluate(edge, ts))
            assert np.linalg.norm(curve - pg.outline_cm[v], axis=1).min() < 0.01   # on the curve, 0.1 mm
            n_notches += 1
    assert n_notches == len(rep["markings"]["notches"]) > 0
    assert rep["markings"]["left"] == []
    for entry in rep["markings"]["notches"]:      # a notch keeps roughly its place along its edge
        assert abs(entry["fraction_graded"] - entry["fraction_base"]) < 0.05


def test_internal_lines_grain_and_drill_holes_move_with_the_panel(graded):
    base, res, rep = graded
    for pb, pg in zip(base.panels, res.panels):
        line_b = np.asarray(pb.extra["internal_lines"][0]["points_cm"])
        line_g = np.asarray(pg.extra["internal_lines"][0]["points_cm"])
        assert not np.allclose(line_b, line_g)                       # moved with the panel
        assert _dist_to_polyline(line_g[0], pg.outline_cm) < 0.01    # its end on the edge stays there
        hole = np.asarray(pg.extra["drill_holes_cm"][0])
        np.testing.assert_allclose(hole, line_g[1], atol=1e-9)       # same point, same map
        gb, gg = np.asarray(pb.extra["grain_line_cm"]), np.asarray(pg.extra["grain_line_cm"])
        db, dg = gb[1] - gb[0], gg[1] - gg[0]
        assert abs(db[0] * dg[1] - db[1] * dg[0]) / (np.linalg.norm(db) * np.linalg.norm(dg)) < 1e-9
    assert set(rep["markings"]["carried"]) == {p.name for p in base.panels}


def test_symmetric_base_stays_symmetric(graded):
    base, res, rep = graded
    found = find_symmetries(base)
    assert {s["panel"] for s in found if s["kind"] == "panel"} == {p.name for p in base.panels}
    for pg in res.panels:
        # measured on its own: each point's mirror image about the panel's vertical centre
        # line lies on the outline, within 0.1 mm
        o = pg.outline_cm
        c = 0.5 * (o[:, 0].min() + o[:, 0].max())
        m = o.copy()
        m[:, 0] = 2 * c - m[:, 0]
        assert max(_dist_to_polyline(p, o) for p in m) < 0.01, pg.name
    assert rep["symmetry"]["max_error_mm"] < 0.1
    assert max(s["moved_mm"] for s in rep["symmetry"]["found"]) > 0.0     # it did have to be put back


def test_carrying_is_exact_for_an_affine_move_and_reports_points_that_leave():
    base = _marked(load_pattern(PATTERN))
    pb = base.panels[0]
    pb.extra["dxf"] = {"texts": [{"text": "label", "at_cm": (pb.outline_cm.mean(axis=0) + [0, 3]).tolist()}]}
    mesh = build_sewn_mesh(base, edge_length_cm=5)
    M, t = np.array([[1.08, 0.02], [0.0, 0.96]]), np.array([3.0, -1.0])
    uv_new = mesh.uv_cm @ M.T + t
    graded = refit_pattern(base, outline_from_uv(mesh, uv_new)).pattern
    rep = carry_markings(base, graded, mesh, uv_new)
    assert rep["left"] == []
    pg = graded.panels[0]
    for key in ("drill_holes_cm",):
        np.testing.assert_allclose(pg.extra[key], np.asarray(pb.extra[key]) @ M.T + t, atol=1e-9)
    np.testing.assert_allclose(pg.extra["internal_lines"][0]["points_cm"],
                               np.asarray(pb.extra["internal_lines"][0]["points_cm"]) @ M.T + t, atol=1e-9)
    np.testing.assert_allclose(pg.extra["dxf"]["texts"][0]["at_cm"],
                               np.asarray(pb.extra["dxf"]["texts"][0]["at_cm"]) @ M.T + t, atol=1e-9)
    # a point off the panel goes with its nearest triangle's affine map: here the same map
    tri = mesh.triangles[mesh.triangle_panel == 0]
    far = pb.outline_cm.max(axis=0) + 5.0
    np.testing.assert_allclose(map_points(far, mesh.uv_cm[tri], uv_new[tri])[0], far @ M.T + t, atol=1e-9)

    # the graded outline pulled in 3 mm past the drill hole near the dart's end: reported
    moved = copy.deepcopy(graded)
    q = moved.panels[0]
    hole = np.asarray(pg.extra["drill_holes_cm"][0])
    k = int(np.argmin(np.linalg.norm(q.outline_cm - hole, axis=1)))
    gap = float(np.linalg.norm(q.outline_cm[k] - hole))
    near = np.linalg.norm(q.outline_cm - q.outline_cm[k], axis=1) < gap + 4.0
    q.outline_cm = q.outline_cm + near[:, None] * (hole - q.outline_cm[k]) * (1.0 + 0.3 / gap)
    rep = carry_markings(base, moved, mesh, uv_new)
    left = [x for x in rep["left"] if x["panel"] == q.name and x["what"] == "drill_holes"]
    assert left and left[0]["problem"] == "left the panel" and left[0]["distance_mm"] > 1.0


def test_left_right_pairs_are_put_back_symmetric():
    pattern = load_pattern(SHARED / "patterns/fs_trousers/size06/pattern.json")
    found = find_symmetries(pattern)
    pairs = [s for s in found if s["kind"] == "pair"]
    assert {frozenset((s["a"], s["b"])) for s in pairs} == {frozenset(("front_right", "front_left")),
                                                           frozenset(("back_right", "back_left"))}
    rng = np.random.default_rng(7)
    outlines = {p.name: p.outline_cm * 1.03 + rng.normal(0, 0.05, p.outline_cm.shape) for p in pattern.panels}
    noisy = copy.deepcopy(pattern)
    for p in noisy.panels:
        p.outline_cm = outlines[p.name].copy()
    assert max(symmetry_error_cm(noisy, s) for s in pairs) > 0.05
    moved = symmetrize(outlines, found)
    for p in noisy.panels:
        p.outline_cm = outlines[p.name]
    assert max(symmetry_error_cm(noisy, s) for s in pairs) < 1e-9
    assert 0 < max(moved.values()) < 3.0                      # mm: only the noise was taken out


def test_an_asymmetric_panel_is_left_alone():
    pattern = load_pattern(PATTERN)
    p = pattern.panels[0]
    p.outline_cm = p.outline_cm.copy()
    p.outline_cm[3] += [0.3, 0.0]                # 3 mm off: no longer symmetric
    assert p.name not in {s.get("panel") for s in find_symmetries(pattern)}
