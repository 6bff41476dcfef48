"""Sewn mesh: seam vertices matched one to one, exact feature points, quality, area, winding,
outline round trip, errors. Every check recomputes what it asserts from the pattern itself."""
from __future__ import annotations

import copy
import threading
from pathlib import Path

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.mesh import build_sewn_mesh, outline_from_uv, sample_boundary
from seamfit.mesh.quality import inside_angles_deg, triangle_angles_deg
from seamfit.mesh.sewn_mesh import loop_vertices_in_range
from seamfit.pattern import load_pattern
from seamfit.pattern.model import Pattern, Stitch, StitchSide, range_indices
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
# sewpat-1 files and GarmentCode's own specifications (read through load_pattern)
FILES = sorted(PATTERNS.glob("*/*/pattern.json")) + sorted(PATTERNS.glob("*/*/native/*_specification.json"))
IDS = [f"{f.parents[1].name}/{f.parent.name}" if f.name == "pattern.json" else f"{f.parents[2].name}/gc-spec"
       for f in FILES]
H = 1.5

_cache: dict = {}


def _load(path: Path) -> Pattern:
    return load_pattern(path)


def _mesh(path: Path, h: float = H):
    key = (str(path), h)
    if key not in _cache:
        p = _load(path)
        _cache[key] = (p, build_sewn_mesh(p, h))
    return _cache[key]


@pytest.fixture(params=FILES, ids=IDS)
def built(request):
    return _mesh(request.param)


def _arc(outline: np.ndarray) -> np.ndarray:
    closed = np.vstack([outline, outline[:1]])
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])


def _arc_of_points(outline: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Arc position of points lying on the closed outline polyline (nearest segment)."""
    arc = _arc(outline)
    a = outline
    b = np.roll(outline, -1, axis=0)
    out = []
    for p in pts:
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
        j = int(np.argmin(d))
        assert d[j] < 1e-9, "boundary vertex is not on the outline"
        out.append(arc[j] + t[j] * (arc[j + 1] - arc[j]))
    return np.array(out)


def _side_fraction(pattern, side: StitchSide, uv: np.ndarray) -> np.ndarray:
    """Fraction of each point along the side's range, in the side's own direction."""
    panel = pattern.panel(side.panel)
    arc = _arc(panel.outline_cm)
    per = arc[-1]
    i0, i1 = side.range
    length = (arc[i1] - arc[i0]) % per
    s = _arc_of_points(panel.outline_cm, uv)
    off = np.mod(s - arc[i0], per)
    off[per - off < 1e-9] = 0.0
    return off / length


# ----------------------------------------------------------------------------- seams

def test_seam_vertex_counts_match_and_pairs_follow_orientation(built):
    pattern, mesh = built
    for k, st in enumerate(pattern.stitches):
        ka, kb = mesh.panel_names.index(st.a.panel), mesh.panel_names.index(st.b.panel)
        va = loop_vertices_in_range(mesh, ka, st.a.range)
        vb = loop_vertices_in_range(mesh, kb, st.b.range)
        assert len(va) == len(vb) >= 2, f"stitch {k}"
        pairs = mesh.stitch_pairs[k]
        # every vertex of both ranges is sewn, once, in orientation order
        assert np.array_equal(pairs[:, 0], va)
        assert np.array_equal(pairs[:, 1], vb[::-1] if st.orientation == "reversed" else vb)
        fa = _side_fraction(pattern, st.a, mesh.uv_cm[pairs[:, 0]])
        fb = _side_fraction(pattern, st.b, mesh.uv_cm[pairs[:, 1]])
        assert fa[0] == pytest.approx(0, abs=1e-9) and fa[-1] == pytest.approx(1, abs=1e-9)
        assert np.all(np.diff(fa) > 0)
        if st.orientation == "reversed":
            assert fb[0] == pytest.approx(1, abs=1e-9) and np.all(np.diff(fb) < 0)
        else:
            assert fb[0] == pytest.approx(0, abs=1e-9) and np.all(np.diff(fb) > 0)
    assert mesh.stats()["max_seam_count_mismatch"] == 0


def test_sewing_pairs_unique_without_self_pairs(built):
    pattern, mesh = built
    sp = mesh.sewing_pairs
    assert sp.dtype == np.int32 and sp.shape[1] == 2 and len(sp) == len(mesh.pair_stitch)
    assert np.all(sp[:, 0] != sp[:, 1])
    keys = {(min(u, v), max(u, v)) for u, v in sp}
    assert len(keys) == len(sp)
    # exactly the distinct non-self pairs of all stitches, each kept for its first stitch
    first = {}
    for k, pairs in enumerate(mesh.stitch_pairs):
        for u, v in pairs:
            if u != v:
                first.setdefault((min(u, v), max(u, v)), k)
    assert keys == set(first)
    for (u, v), k in zip(sp, mesh.pair_stitch):
        assert first[(min(u, v), max(u, v))] == k
        assert mesh.boundary[u] and mesh.boundary[v]
        st = pattern.stitches[k]
        assert mesh.panel_names[mesh.vertex_panel[u]] == st.a.panel
        assert mesh.panel_names[mesh.vertex_panel[v]] == st.b.panel


def test_dart_tips_and_shared_ends_are_not_duplicated():
    pattern, mesh = _mesh(PATTERNS / "fs_bodice/size06/pattern.json")
    darts = [k for k, st in enumerate(pattern.stitches) if st.a.panel == st.b.panel]
    assert darts
    for k in darts:
        tip_pairs = [(u, v) for u, v in mesh.stitch_pairs[k] if u == v]
        assert len(tip_pairs) == 1                   # both legs end at the tip
        tip = tip_pairs[0][0]
        assert not np.any((mesh.sewing_pairs[:, 0] == tip) & (mesh.sewing_pairs[:, 1] == tip))
    total = sum(len(p) for p in mesh.stitch_pairs)
    assert len(mesh.sewing_pairs) == total - len(darts) - _duplicates(mesh)


def _duplicates(mesh) -> int:
    seen, dup = set(), 0
    for pairs in mesh.stitch_pairs:
        for u, v in pairs:
            if u == v:
                continue
            key = (min(u, v), max(u, v))
            dup += key in seen
            seen.add(key)
    return dup


def test_gathered_stitches_spread_pairs_in_proportion():
    gathered = 0
    for path in FILES:
        pattern, mesh = _mesh(path)
        for k, st in enumerate(pattern.stitches):
            if not st.gathered:
                continue
            gathered += 1
            pairs = mesh.stitch_pairs[k]
            fa = _side_fraction(pattern, st.a, mesh.uv_cm[pairs[:, 0]])
            fb = _side_fraction(pattern, st.b, mesh.uv_cm[pairs[:, 1]])
            fb_in_a = 1 - fb if st.orientation == "reversed" else fb
            la = np.sum(np.linalg.norm(np.diff(pattern.panel(st.a.panel).outline_cm[
                range_indices(st.a.range, pattern.panel(st.a.panel).n_vertices)], axis=0), axis=1))
            lb = np.sum(np.linalg.norm(np.diff(pattern.panel(st.b.panel).outline_cm[
                range_indices(st.b.range, pattern.panel(st.b.panel).n_vertices)], axis=0), axis=1))
            assert abs(la - lb) > 0.5                          # really gathered
            # pairs sit at the same fraction of both sides, so the vertex spacing differs
            # between the sides in the ratio of their lengths (no breakpoints inside these)
            assert np.abs(fa - fb_in_a).max() < 1e-9
            # ... each side evenly spaced along its own length: spacing ratio = length ratio
            da, db = np.diff(fa) * la, np.abs(np.diff(fb)) * lb
            assert np.allclose(da, la / (len(fa) - 1), rtol=1e-6)
            assert np.allclose(da / db, la / lb, rtol=1e-6)
    assert gathered >= 4


def test_breakpoints_cross_each_seam():
    """A breakpoint inside one side of a stitch is sewn to the other side at the same fraction,
    or to a breakpoint of the other side within the merge tolerance (h / 2)."""
    checked = 0
    for path in FILES:
        pattern, mesh = _mesh(path)
        for k, st in enumerate(pattern.stitches):
            pairs = mesh.stitch_pairs[k]
            fa = _side_fraction(pattern, st.a, mesh.uv_cm[pairs[:, 0]])
            fb = _side_fraction(pattern, st.b, mesh.uv_cm[pairs[:, 1]])
            fb_in_a = 1 - fb if st.orientation == "reversed" else fb
            lmax = max(_side_length(pattern, st.a), _side_length(pattern, st.b))
            feats = [_features(pattern, side, mesh) for side in (st.a, st.b)]
            for j, (u, v) in enumerate(pairs):
                if u in feats[0] or v in feats[1]:
                    checked += 1
                    same = abs(fa[j] - fb_in_a[j]) < 1e-9
                    matched = u in feats[0] and v in feats[1] and abs(fa[j] - fb_in_a[j]) * lmax < H / 2
                    assert same or matched, f"{path}: stitch {k} pair {j}"
    assert checked > 0


def _side_length(pattern, side) -> float:
    panel = pattern.panel(side.panel)
    return float(np.sum(np.linalg.norm(np.diff(panel.outline_cm[range_indices(side.range, panel.n_vertices)],
                                               axis=0), axis=1)))


def _features(pattern, side, mesh) -> set[int]:
    panel = pattern.panel(side.panel)
    om = mesh.outline_maps[mesh.panel_names.index(side.panel)]
    feats = set(panel.nodes) | set(panel.corners) | set(panel.landmarks.values())
    for st in pattern.stitches:
        for s in (st.a, st.b):
            if s.panel == side.panel:
                feats.update(s.range)
    return {int(om.vertex[i]) for i in feats}


def _strip(name: str, bottom_x: list[float], height: float, u0: float) -> "Panel":
    """A ccw rectangle whose bottom edge has outline points at bottom_x (all nodes)."""
    from seamfit.pattern.model import Panel, Placement
    xs = np.asarray(bottom_x, dtype=float)
    outline = np.vstack([np.column_stack([u0 + xs, np.zeros(len(xs))]),
                         [[u0 + xs[-1], height], [u0 + xs[0], height]]])
    n = len(outline)
    return Panel(name=name, outline_cm=outline, orientation="ccw", nodes=[0, len(xs) - 1, n - 1],
                 corners=[0, len(xs) - 1, n - 2, n - 1], landmarks={}, edges=[],
                 placement=Placement(kind="hint", rotation=np.eye(3), translation_m=np.zeros(3)))


def test_breakpoints_matched_or_copied_across_a_seam():
    # side a: 30 cm with nodes at 10 and 20; side b: 30.6 cm with nodes at 10.3 and 25
    xa = sorted(set(np.arange(0.0, 30.01, 1.0).round(6)))
    xb = sorted(set(np.arange(0.0, 30.61, 1.0).round(6)) | {10.3, 25.0, 30.6})
    a, b = _strip("a", xa, 8.0, 0.0), _strip("b", xb, 8.0, 40.0)
    a.nodes += [xa.index(10.0), xa.index(20.0)]
    a.landmarks = {"notch": xa.index(20.0)}
    b.nodes += [xb.index(10.3), xb.index(25.0)]
    st = Stitch(kind="seam", a=StitchSide("a", (0, len(xa) - 1)), b=StitchSide("b", (0, len(xb) - 1)),
                orientation="same")
    pattern = Pattern(panels=[a, b], stitches=[st], source_file="<test>")
    mesh = build_sewn_mesh(pattern, H)
    pairs = mesh.stitch_pairs[0]
    va = {x: mesh.outline_maps[0].vertex[xa.index(x)] for x in (10.0, 20.0)}
    vb = {x: mesh.outline_maps[1].vertex[xb.index(x)] for x in (10.3, 25.0)}
    partner = dict(zip(pairs[:, 0].tolist(), pairs[:, 1].tolist()))
    # 10 and 10.3 are one feature drafted 0.3 cm apart: matched
    assert partner[va[10.0]] == vb[10.3]
    # 20 on a has no counterpart: copied to b at the same fraction of the piece between the
    # matched knot (10 <-> 10.3) and the end (30 <-> 30.6)
    assert mesh.uv_cm[partner[va[20.0]]][0] - 40.0 == pytest.approx(10.3 + 0.5 * (30.6 - 10.3), abs=1e-9)
    # 25 on b: copied back to a the same way
    back = {v: u for u, v in partner.items()}
    f = (25.0 - 10.3) / (30.6 - 10.3)
    assert mesh.uv_cm[back[vb[25.0]]][0] == pytest.approx(10.0 + f * 20.0, abs=1e-9)
    assert mesh.stats()["max_seam_count_mismatch"] == 0
    # pieces between knots are cut alike on both sides
    assert np.all(np.diff(mesh.uv_cm[pairs[:, 0], 0]) > 0) and np.all(np.diff(mesh.uv_cm[pairs[:, 1], 0]) > 0)


# ----------------------------------------------------------------------------- geometry

def test_corners_landmarks_nodes_are_exact_vertices(built):
    pattern, mesh = built
    for k, panel in enumerate(pattern.panels):
        om = mesh.outline_maps[k]
        ends = [i for st in pattern.stitches for s in (st.a, st.b) if s.panel == panel.name for i in s.range]
        for i in set(panel.corners) | set(panel.nodes) | set(ends):
            v = om.vertex[i]
            assert v >= 0, f"{panel.name}: outline point {i} is not a vertex"
            assert np.array_equal(mesh.uv_cm[v], panel.outline_cm[i])
            assert mesh.boundary[v] and mesh.vertex_panel[v] == k
        for i in panel.corners:
            assert mesh.corner[om.vertex[i]]
        for name, i in panel.landmarks.items():
            v = mesh.landmark_vertex[(panel.name, name)]
            assert np.array_equal(mesh.uv_cm[v], panel.outline_cm[i])
        assert mesh.corner[mesh.boundary_loops[k]].sum() == len(set(panel.corners))
    assert not np.any(mesh.corner & ~mesh.boundary)


def test_boundary_is_exactly_the_sampled_loop(built):
    """gmsh added no boundary point: each panel's free triangle edges are exactly the loop's segments."""
    pattern, mesh = built
    for k, loop in enumerate(mesh.boundary_loops):
        tris = mesh.panel_triangles(k)
        edges = np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
        uniq, count = np.unique(edges, axis=0, return_counts=True)
        assert count.max() <= 2                         # a manifold
        free = {tuple(e) for e in uniq[count == 1]}
        ring = {tuple(sorted((int(a), int(b)))) for a, b in zip(loop, np.roll(loop, -1))}
        assert free == ring
        assert set(np.unique(tris)) == set(mesh.panel_vertices(k))
        assert np.array_equal(np.nonzero(mesh.boundary & (mesh.vertex_panel == k))[0], np.sort(loop))
        # the loop runs along the outline in index order
        s = _arc_of_points(pattern.panels[k].outline_cm, mesh.uv_cm[loop])
        start = int(np.argmin(s))
        assert np.all(np.diff(np.roll(s, -start)) > 0)


def test_boundary_spacing_about_edge_length(built):
    _, mesh = built
    seg = np.concatenate([np.linalg.norm(mesh.uv_cm[np.roll(lp, -1)] - mesh.uv_cm[lp], axis=1)
                          for lp in mesh.boundary_loops])
    assert seg.max() <= 1.5 * H + 1e-9
    assert 0.85 * H < np.median(seg) < 1.1 * H


def test_min_angle(built):
    pattern, mesh = built
    st = mesh.stats()
    ang = triangle_angles_deg(mesh.uv_cm, mesh.triangles).min(axis=1)
    assert st["min_angle_deg"] == pytest.approx(ang.min())
    # these patterns have no corner sharper than 50 deg (dart tips point inwards), so every
    # triangle counts; docs/meshing.md reports >= 36 deg on all shared patterns
    assert st["sharp_corners"] == 0
    assert st["min_angle_interior_deg"] >= 25.0
    assert st["min_angle_deg"] >= 25.0


def test_sharp_corner_is_reported_apart():
    """A panel with a 20 deg point: the triangle there is excused, all others stay >= 25 deg."""
    tip = np.radians(20.0)
    r = 30.0
    outline = [[0.0, 0.0], [r * np.cos(tip / 2), -r * np.sin(tip / 2)], [r + 4.0, 0.0],
               [r * np.cos(tip / 2), r * np.sin(tip / 2)]]
    pattern = _one_panel_pattern(np.array(outline), corners=[0, 1, 2, 3])
    mesh = build_sewn_mesh(pattern, 1.5)
    st = mesh.stats()
    sharp = mesh.sharp_vertices()
    assert len(sharp) == 1 and np.array_equal(mesh.uv_cm[sharp[0]], [0.0, 0.0])
    assert inside_angles_deg(mesh.uv_cm[mesh.boundary_loops[0]]).min() == pytest.approx(20.0)
    assert st["min_angle_deg"] <= 20.0 + 1e-9
    assert st["min_angle_interior_deg"] >= 25.0


def test_short_outline_edge_grades_the_spacing():
    """A 0.4 cm edge beside a right angle: the neighbouring segments shrink towards it instead of
    leaving a thin triangle between a 0.4 cm and a 1.5 cm segment."""
    outline = np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 0.4], [20.0, 10.0], [0.0, 10.0]])
    mesh = build_sewn_mesh(_one_panel_pattern(outline, corners=[0, 1, 2, 3, 4]), H)
    loop = mesh.boundary_loops[0]
    seg = np.linalg.norm(mesh.uv_cm[np.roll(loop, -1)] - mesh.uv_cm[loop], axis=1)
    short = int(np.argmin(seg))
    assert seg[short] == pytest.approx(0.4)
    before, after = seg[short - 1], seg[(short + 1) % len(seg)]
    assert before < 0.6 and after < 0.6
    ratio = np.maximum(seg / np.roll(seg, 1), np.roll(seg, 1) / seg)
    assert ratio.max() < 1.5
    assert mesh.stats()["min_angle_deg"] >= 25.0


def test_area_preserved(built):
    pattern, mesh = built
    st = mesh.stats()
    for k, panel in enumerate(pattern.panels):
        tris = mesh.panel_triangles(k)
        a, b, c = (mesh.uv_cm[tris[:, j]] for j in range(3))
        area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
        err = abs(area.sum() - abs(panel.signed_area_cm2())) / abs(panel.signed_area_cm2())
        assert err < 0.005, panel.name
        assert st["area_error"][panel.name] == pytest.approx(err, abs=1e-12)


def test_winding_gives_outward_normal_in_3d(built):
    pattern, mesh = built
    for k, panel in enumerate(pattern.panels):
        r = panel.placement.rotation
        outward = r @ np.array([0.0, 0.0, 1.0 if panel.orientation == "ccw" else -1.0])
        idx = mesh.panel_vertices(k)
        # placement: world = R @ [0.01 u, 0.01 v, 0] + t
        expect = (np.column_stack([0.01 * mesh.uv_cm[idx], np.zeros(len(idx))]) @ r.T
                  + panel.placement.translation_m)
        assert np.allclose(mesh.x0[idx], expect, atol=1e-12)
        tris = mesh.panel_triangles(k)
        x = mesh.x0
        n = np.cross(x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]])
        assert np.all(n @ outward > 0), panel.name
        assert np.allclose(mesh.outward_normals[k], outward)


def test_finer_edge_length_gives_proportionally_more_vertices():
    path = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
    _, fine = _mesh(path, 1.5)
    _, coarse = _mesh(path, 3.0)
    b_ratio = fine.boundary.sum() / coarse.boundary.sum()
    v_ratio = fine.n_vertices / coarse.n_vertices
    t_ratio = len(fine.triangles) / len(coarse.triangles)
    assert 1.7 < b_ratio < 2.3             # boundary ~ 1/h
    assert 3.3 < v_ratio < 4.7             # area ~ 1/h^2
    assert 3.3 < t_ratio < 4.7
    assert coarse.stats()["max_seam_count_mismatch"] == 0


# ----------------------------------------------------------------------------- outline map

def test_outline_from_uv_reproduces_outline(built):
    pattern, mesh = built
    exact = outline_from_uv(mesh, mesh.uv_cm)
    chords = outline_from_uv(mesh, mesh.uv_cm, detail=False)
    for k, panel in enumerate(pattern.panels):
        o = panel.outline_cm
        assert exact[panel.name].shape == o.shape
        assert np.abs(exact[panel.name] - o).max() < 1e-6
        om = mesh.outline_maps[k]
        on = om.vertex >= 0
        assert np.abs(chords[panel.name][on] - o[on]).max() < 1e-6
        # between vertices the chord is off the outline by no more than the outline itself strays
        # from that chord
        d = np.linalg.norm(chords[panel.name] - o, axis=1)
        for i in np.nonzero(~on)[0]:
            a, b = mesh.uv_cm[om.a[i]], mesh.uv_cm[om.b[i]]
            sag = _max_distance_to_line(_outline_between(panel.outline_cm, a, b), a, b)
            assert d[i] <= sag + 1e-9


def _outline_between(outline: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    sa, sb = _arc_of_points(outline, np.array([a, b]))
    arc = _arc(outline)
    per = arc[-1]
    length = (sb - sa) % per
    inside = np.mod(arc[:-1] - sa, per) <= length
    return outline[inside]


def _max_distance_to_line(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    return float(np.max(np.abs(d[0] * (pts[:, 1] - a[1]) - d[1] * (pts[:, 0] - a[0])) / np.linalg.norm(d)))


def test_outline_follows_a_similarity_of_the_boundary():
    pattern, mesh = _mesh(PATTERNS / "gc_circle_skirt/size06/pattern.json")
    ang, scale, shift = 0.3, 1.07, np.array([5.0, -2.0])
    rot = scale * np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    moved = outline_from_uv(mesh, mesh.uv_cm @ rot.T + shift)
    for panel in pattern.panels:
        assert np.allclose(moved[panel.name], panel.outline_cm @ rot.T + shift, atol=1e-9)


# ----------------------------------------------------------------------------- API details

def test_stats_and_cache_key():
    path = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
    pattern, mesh = _mesh(path)
    st = mesh.stats()
    assert st["vertices"] == mesh.n_vertices == len(mesh.x0) == len(mesh.vertex_panel)
    assert st["triangles"] == len(mesh.triangles) == len(mesh.triangle_panel)
    assert st["stitches"] == len(pattern.stitches) and st["sewing_pairs"] == len(mesh.sewing_pairs)
    assert set(st["area_error"]) == {p.name for p in pattern.panels}
    assert mesh.triangles.dtype == np.int32 and mesh.sewing_pairs.dtype == np.int32
    again = build_sewn_mesh(_load(path), H)
    assert again.cache_key() == mesh.cache_key()
    assert _mesh(path, 3.0)[1].cache_key() != mesh.cache_key()


def test_build_in_worker_thread_matches_main_thread():
    import gmsh
    path = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
    main_key = _mesh(path, 3.0)[1].cache_key()
    keys, errors = [], []

    def work():
        try:
            keys.append(build_sewn_mesh(_load(path), 3.0).cache_key())
        except Exception as exc:  # reported below
            errors.append(exc)
    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and keys == [main_key, main_key]
    assert not gmsh.isInitialized()            # no gmsh state left behind


# ----------------------------------------------------------------------------- errors

def _pencil() -> Pattern:
    return copy.deepcopy(_mesh(PATTERNS / "gc_pencil_skirt/size06/pattern.json")[0])


def test_range_out_of_bounds_is_named():
    p = _pencil()
    n = p.panel(p.stitches[7].b.panel).n_vertices
    p.stitches[7].b.range = (p.stitches[7].b.range[0], n + 5)
    with pytest.raises(PatternError) as err:
        build_sewn_mesh(p)
    msg = str(err.value)
    assert str(p.source_file) in msg and "stitch 7" in msg and repr(p.stitches[7].b.panel) in msg
    assert str(n + 5) in msg


def test_unknown_panel_is_named():
    p = _pencil()
    p.stitches[3].a.panel = "sleeve_nowhere"
    with pytest.raises(PatternError, match=r"stitch 3.*'sleeve_nowhere'"):
        build_sewn_mesh(p)


def test_segment_sewn_twice_is_rejected():
    p = _pencil()
    st = p.stitches[6]
    p.stitches.append(Stitch(kind="seam", a=StitchSide(st.a.panel, st.a.range),
                             b=StitchSide(st.b.panel, st.b.range), orientation="reversed"))
    with pytest.raises(PatternError, match=r"stitch 20.*already sewn by stitch 6"):
        build_sewn_mesh(p)


def test_orientation_that_contradicts_the_outline_is_rejected():
    p = _pencil()
    p.panels[0].orientation = "ccw" if p.panels[0].orientation == "cw" else "cw"
    with pytest.raises(PatternError, match=repr(p.panels[0].name)):
        build_sewn_mesh(p)


def test_bad_edge_length():
    with pytest.raises(ValueError):
        sample_boundary(_pencil(), 0.0)


# ----------------------------------------------------------------------------- helpers

def _one_panel_pattern(outline: np.ndarray, corners: list[int]) -> Pattern:
    from seamfit.pattern.model import Panel, Placement
    panel = Panel(name="piece", outline_cm=outline, orientation="ccw", nodes=list(corners),
                  corners=list(corners), landmarks={}, edges=[],
                  placement=Placement(kind="hint", rotation=np.eye(3), translation_m=np.zeros(3)))
    return Pattern(panels=[panel], stitches=[], source_file="<test>")
