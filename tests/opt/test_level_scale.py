"""The measurement-aware start (seamfit.opt.level_scale): equal bodies give the base pattern
back; a body grown around its axis grows the pattern's widths by what the body girth grew,
and leaves its lengths."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from common import SAMPLES



@pytest.fixture(scope="module")
def skirt():
    from seamfit.body import build_sdf, load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.opt.grade import base_drape
    from seamfit.pattern import load_pattern
    from seamfit.sim.model import Fabric, SimSettings

    pattern = load_pattern(SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json")
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    mesh = build_sewn_mesh(pattern, edge_length_cm=4.0)
    sdf = build_sdf(body, spacing=0.005)
    xbar, _ = base_drape(mesh, pattern, body, sdf, Fabric(), SimSettings())
    return mesh, xbar, body, sdf


def _widened(body, k: float):
    """The body scaled by k across (x, y) about its vertical axis; heights unchanged."""
    v = np.array(body.vertices, dtype=float)
    c = 0.5 * (v[:, :2].min(axis=0) + v[:, :2].max(axis=0))
    v[:, :2] = c + k * (v[:, :2] - c)
    return replace(body, vertices=v)


def test_equal_bodies_give_the_base_pattern(skirt):
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    p = level_scaled_pattern(mesh, xbar, body, body, sdf)
    assert np.max(np.abs(p - 0.01 * mesh.uv_cm)) < 1e-9


def test_widths_grow_by_the_girth_the_garment_encloses(skirt):
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    k = 1.06
    target = _widened(body, k)
    p = level_scaled_pattern(mesh, xbar, body, target, sdf)
    assert np.all(np.isfinite(p))
    hip_growth_cm = body_measurements(target)["hip"] - body_measurements(body)["hip"]
    # The two skirt panels go once around the body: their widths together grow by what
    # the hip grew (their hems hang from it), and their lengths stay.
    grow_w, grow_h = 0.0, []
    vp = np.asarray(mesh.vertex_panel)
    for i, name in enumerate(mesh.panel_names):
        if not name.startswith("skirt"):
            continue
        a, b = mesh.uv_cm[vp == i], 100.0 * p[vp == i]
        grow_w += np.ptp(b[:, 0]) - np.ptp(a[:, 0])
        grow_h.append(np.ptp(b[:, 1]) - np.ptp(a[:, 1]))
    assert grow_w == pytest.approx(hip_growth_cm, rel=0.2)
    assert max(abs(h) for h in grow_h) < 0.5


def _stretched_up(body, k: float):
    """The body scaled by k in height about its soles."""
    v = np.array(body.vertices, dtype=float)
    z0 = v[:, 2].min()
    v[:, 2] = z0 + k * (v[:, 2] - z0)
    return replace(body, vertices=v)


def _with_belly(body, depth_m: float):
    """The body with its front pushed forward (-y) between the hip and the bust, most at
    mid-height: a full belly, with no vertex moved up or down."""
    from seamfit.body.measure import body_measurements
    lv = body_measurements(body)["levels_z_m"]
    v = np.array(body.vertices, dtype=float)
    lo, hi = lv["hip"], lv["bust"]
    cy = 0.5 * (v[:, 1].min() + v[:, 1].max())
    s = np.clip((v[:, 2] - lo) / (hi - lo), 0.0, 1.0)
    front = (v[:, 1] < cy) & (s > 0) & (s < 1)
    v[front, 1] -= depth_m * np.sin(np.pi * s[front])
    return replace(body, vertices=v)


def _grown_between(body, k: float, z_full: float, z_none: float):
    """The body widened about its vertical axis by k at z_full, by 1 at z_none, linearly
    between, and as at the nearer of the two beyond them; heights unchanged."""
    v = np.array(body.vertices, dtype=float)
    c = 0.5 * (v[:, :2].min(axis=0) + v[:, :2].max(axis=0))
    s = 1.0 + (k - 1.0) * np.clip((z_none - v[:, 2]) / (z_none - z_full), 0.0, 1.0)
    v[:, :2] = c + s[:, None] * (v[:, :2] - c)
    return replace(body, vertices=v)


def _dart_rows(mesh, xbar, p, profile):
    """Per dart of the level-scaled pattern p: (its intake's stretch, the stretch of the
    panel's row at its open end, sx at its open end, sx at its tip, the stretch the rule
    gives its intake: sx_tip + (sx_tip - sx_open) C / I)."""
    from seamfit.opt.level_scale import DART_ROW_M, _darts
    uv = 0.01 * np.asarray(mesh.uv_cm, dtype=float)
    vp = np.asarray(mesh.vertex_panel)
    darts = _darts(mesh, xbar)
    out = []
    for d in darts:
        a, b = d["legs"]
        pv = np.flatnonzero(vp == d["panel"])
        row = pv[np.abs((uv[pv] - d["mid"]) @ d["along"]) < DART_ROW_M]
        width = np.ptp(uv[row] @ d["across"])
        intake = sum(e["intake"] for e in darts if e["panel"] == d["panel"]
                     and abs((e["mid"] - d["mid"]) @ d["along"]) < DART_ROW_M)
        grown = abs((p[a[-1]] - p[b[-1]]) @ d["across"]) / d["intake"]
        sx_open, sx_tip = np.interp([d["z_open"], d["z_tip"]], profile["z"], profile["sx"])
        rule = sx_tip + (sx_tip - sx_open) * (width - intake) / intake
        out.append((grown, np.ptp(p[row] @ d["across"]) / width, sx_open, sx_tip, rule))
    return out


def test_a_dart_takes_up_what_the_girth_at_its_tip_grew_beyond_its_open_end(skirt):
    # Hips wider, waist as it was: the side seams keep their shape (the row at the darts'
    # open ends grows as the hip's did) and the darts take up the difference.
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    lv = body_measurements(body)["levels_z_m"]
    for full, none, widens in ((lv["hip"], lv["waist"], True), (lv["waist"], lv["hip"], False)):
        p, info = level_scaled_pattern(mesh, xbar, body, _grown_between(body, 1.08, full, none),
                                       sdf, return_info=True)
        rows = _dart_rows(mesh, xbar, p, info["profile"])
        assert len(rows) == 6                       # 2 front, 4 back darts
        for grown, row_stretch, sx_open, sx_tip, rule in rows:
            assert abs(sx_tip - sx_open) > 0.03
            assert abs(row_stretch - sx_tip) < 0.2 * abs(sx_tip - sx_open)
            assert (grown > 1.1) if widens else (grown < 0.97)
            assert grown == pytest.approx(rule, abs=0.05)


def test_a_taller_body_maps_every_level_up_in_proportion():
    from seamfit.body import load_body
    from seamfit.opt.level_scale import level_map
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    zb, zt = level_map(body, _stretched_up(body, 1.05))
    z0 = body.vertices[:, 2].min()
    assert len(zb) == 5                          # soles, crotch, waist, armpit, crown
    assert np.allclose(zt - z0, 1.05 * (zb - z0), atol=1e-6)


def test_levels_follow_the_body_sections_not_the_target_s_own_measurements():
    # A belly moves the narrowest girth (the waist a tape would find) towards the bust;
    # the garment's levels stay with the body sections, which did not move up or down.
    from seamfit.body import load_body
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import level_map
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    bellied = _with_belly(body, 0.06)
    moved = body_measurements(bellied)["levels_z_m"]["waist"] - body_measurements(body)["levels_z_m"]["waist"]
    assert abs(moved) > 0.005                    # the target's own waist rule lands elsewhere
    zb, zt = level_map(body, bellied)
    assert np.max(np.abs(zt - zb)) < 1e-9


def test_a_skirt_passes_the_crotch_as_one_tube(skirt):
    from seamfit.opt.level_scale import passes_crotch_as_one_tube
    mesh, xbar, body, sdf = skirt
    assert passes_crotch_as_one_tube(mesh, xbar, body)
    # Cut off below the hip, the same garment ends above the crotch: it passes nothing.
    top = xbar.copy()
    top[:, 2] = np.maximum(top[:, 2], body.vertices[:, 2].max() * 0.55)
    assert not passes_crotch_as_one_tube(mesh, top, body)


def _tube(cx: float, r: float = 0.1, n: int = 12, zs=(0.0, 0.2, 0.4), offset: int = 0):
    """A tube of two half-cylinder panels (separate vertices) sewn along both sides:
    (vertices, triangles, sewing pairs)."""
    verts, tris, pairs = [], [], []
    cols = []
    for half in (0, 1):
        a = np.linspace(np.pi * half, np.pi * (half + 1), n // 2 + 1)
        base = offset + len(verts)
        for z in zs:
            for t in a:
                verts.append((cx + r * np.cos(t), r * np.sin(t), z))
        w = len(a)
        for i in range(len(zs) - 1):
            for j in range(w - 1):
                v0 = base + i * w + j
                tris += [(v0, v0 + 1, v0 + w), (v0 + 1, v0 + w + 1, v0 + w)]
        cols.append((base, w))
    (b0, w), (b1, _) = cols
    for i in range(len(zs)):
        pairs.append((b0 + i * w + w - 1, b1 + i * w))      # angle pi: end of panel 0, start of panel 1
        pairs.append((b1 + i * w + w - 1, b0 + i * w))      # angle 2 pi = 0
    return np.array(verts), np.array(tris), np.array(pairs)


def test_a_section_counts_its_closed_pieces_from_the_mesh_not_from_where_it_hangs():
    from types import SimpleNamespace

    from seamfit.opt.level_scale import section_loops
    v0, t0, s0 = _tube(-0.1)
    # The second leg touches the first between them (x = 0): still two tubes.
    v1, t1, s1 = _tube(0.1, offset=len(v0))
    legs = SimpleNamespace(triangles=np.vstack([t0, t1]), sewing_pairs=np.vstack([s0, s1]))
    x = np.vstack([v0, v1])
    assert section_loops(legs, x, 0.1) == 2
    assert section_loops(legs, x, 0.5) == 0                  # above the garment
    one = SimpleNamespace(triangles=t0, sewing_pairs=s0)
    assert section_loops(one, v0, 0.3) == 1
    # Unsewn, the two panels of one tube are two pieces.
    assert section_loops(SimpleNamespace(triangles=t0, sewing_pairs=np.zeros((0, 2), int)), v0, 0.3) == 2


def test_the_skirt_section_below_the_crotch_is_one_piece(skirt):
    from seamfit.opt.level_scale import base_levels, section_loops
    mesh, xbar, body, sdf = skirt
    crotch = base_levels(body)["crotch"]
    assert section_loops(mesh, xbar, 0.5 * (crotch + xbar[:, 2].min())) == 1


def test_a_level_cut_through_the_triangles_that_straddle_it_is_the_whole_mesh_cut(skirt):
    # girth_profile cuts each level through the triangles that straddle it only: the same
    # points in the same order, the same cloth length and the same pieces, to the bit.
    from seamfit.opt.fit import mesh_cross_section
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from seamfit.opt.level_scale import _pieces, cloth_length, section_loops
    mesh, xbar, body, sdf = skirt
    tri = np.asarray(mesh.triangles)
    tz = xbar[tri, 2]
    pairs = np.asarray(mesh.sewing_pairs, dtype=np.int64).reshape(-1, 2)
    # levels between the vertices and at their very heights
    zs = np.concatenate([np.linspace(tz.min() - 0.01, tz.max() + 0.01, 41), xbar[::37, 2]])
    for z in zs:
        at = tri[(tz.min(axis=1) < z) & (tz.max(axis=1) > z)]
        assert mesh_cross_section(xbar, at, z).tobytes() == mesh_cross_section(xbar, tri, z).tobytes()
        assert cloth_length(xbar, at, z) == cloth_length(xbar, tri, z)
        # the pieces as counted over a graph of every vertex of the mesh
        cut = tri[(tz.min(axis=1) < z) & (tz.max(axis=1) > z)]
        whole = 0
        if len(cut):
            used = np.zeros(len(xbar), dtype=bool)
            used[cut.ravel()] = True
            e = np.vstack([cut[:, [0, 1]], cut[:, [1, 2]], pairs[used[pairs[:, 0]] & used[pairs[:, 1]]]])
            g = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(xbar), len(xbar)))
            whole = len(np.unique(connected_components(g, directed=False)[1][used]))
        assert _pieces(at, pairs, len(xbar)) == section_loops(mesh, xbar, z) == whole


def test_the_height_map_goes_on_beyond_the_soles_with_its_end_slope():
    # A floor-length garment hangs below the soles: clamping the map there would give its
    # hem no vertical stretch at all.
    from seamfit.opt.level_scale import map_height
    zb, zt = np.array([0.0, 0.8, 1.6]), np.array([0.0, 0.76, 1.6])
    z = np.array([-0.02, 0.4, 1.7])
    out = map_height(z, zb, zt)
    assert np.allclose(out, [-0.02 * 0.95, 0.38, 1.6 + 0.1 * 0.84 / 0.8])


def _ring_around(points_xy: np.ndarray, out_m: float, n: int = 48) -> np.ndarray:
    """Points on the convex hull of ``points_xy`` pushed out by ``out_m`` (cloth around it)."""
    from scipy.spatial import ConvexHull
    h = points_xy[ConvexHull(points_xy).vertices]
    c = h.mean(axis=0)
    ang = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    rays = np.column_stack([np.cos(ang), np.sin(ang)])
    # the hull's extent along each ray, plus the offset
    r = np.array([np.max((h - c) @ d) for d in rays]) + out_m
    return c + rays * r[:, None]


def test_a_top_s_girth_under_the_arms_is_the_torso_s_not_the_hull_around_its_sleeves():
    from seamfit.body import load_body
    from seamfit.body.measure import _Slicer, body_measurements
    from seamfit.opt.level_scale import _enclosed_growth, _hull, _hull_perimeter
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    lv = body_measurements(body)["levels_z_m"]
    z = lv["armpit"] - 0.03                       # arms are loops of their own here
    s = _Slicer(body)
    _, _, _, pts = s.cut(z)
    ids = s.torso_ids(z)
    arm = np.setdiff1d(np.arange(len(pts)), ids)
    assert len(ids) >= 3 and len(arm) >= 3
    torso_cloth = _ring_around(pts[ids], 0.01)
    left = pts[arm][pts[arm][:, 0] > 0]
    right = pts[arm][pts[arm][:, 0] < 0]
    sleeves = np.vstack([_ring_around(left, 0.01), _ring_around(right, 0.01)])
    garment = np.vstack([torso_cloth, sleeves])
    g, h0, h1 = _enclosed_growth(s, body.vertices, z, garment)
    torso_g = _hull_perimeter(_hull(torso_cloth))
    around_all = _hull_perimeter(_hull(garment))
    assert g == pytest.approx(torso_g, rel=1e-9)
    assert around_all > 1.3 * g                   # the hull around the sleeves is far longer
    assert h0 == pytest.approx(s.girth(z), rel=1e-6)   # the torso's own tape girth
    assert h1 == pytest.approx(h0, rel=1e-12)     # same body: no growth
    # A garment without sleeves at that level keeps its whole section.
    g2, h02, _ = _enclosed_growth(s, body.vertices, z, torso_cloth)
    assert g2 == pytest.approx(torso_g, rel=1e-9) and h02 == pytest.approx(h0, rel=1e-9)


def test_body_points_a_coarse_cloth_ring_cuts_off_still_count_as_under_it():
    # A 3 cm mesh's flat triangles cut chords through a convex body part: the bust's most
    # prominent points lie a millimetre or two outside the cloth's hull. They are the ones
    # a fuller bust moves most; left out, the FreeSewing bodice's bust level grew 14.3 cm
    # where the body's tape grew 16.4 cm.
    from seamfit.body import load_body
    from seamfit.body.measure import _Slicer, body_measurements
    from seamfit.opt.level_scale import _enclosed_growth
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    z = body_measurements(body)["levels_z_m"]["bust"]
    s = _Slicer(body)
    torso = s.cut(z)[3][s.torso_ids(z)]
    coarse = _ring_around(torso, 0.001, n=16)      # cloth points 5-6 cm apart, 1 mm out
    eq = _hull(coarse).equations
    assert (torso @ eq[:, :2].T + eq[:, 2]).max() > 0.001   # the chords cut into the body
    k = 1.1
    g, h0, h1 = _enclosed_growth(s, _widened(body, k).vertices, z, coarse)
    assert h0 == pytest.approx(s.girth(z), rel=1e-6)
    assert h1 - h0 == pytest.approx((k - 1.0) * h0, rel=1e-6)


def _hull(points):
    from scipy.spatial import ConvexHull
    return ConvexHull(points)


def _shoulders_raised(body, dz: float, armpit_z: float, shoulder_z: float):
    """The body with dz more between its armpit and its shoulders: every vertex above the
    armpit moves up, by dz from shoulder_z up (the head as it was)."""
    v = np.array(body.vertices, dtype=float)
    v[:, 2] += dz * np.clip((v[:, 2] - armpit_z) / (shoulder_z - armpit_z), 0.0, 1.0)
    return replace(body, vertices=v)


def test_the_armhole_deepens_by_what_the_body_grew_between_armpit_and_shoulders():
    # A fuller body at the same stature grows between the armpit and the shoulders, not in
    # the head: the height map follows the shoulder line's landmarks, so that span takes
    # all of the growth (drafts deepen the armhole by it) and the neck and head none.
    from seamfit.body import load_body
    from seamfit.body.shape_model import hm08_landmarks
    from seamfit.opt.level_scale import SHOULDER_LINE, base_levels, level_map, map_height, with_shoulder_line
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    lm = hm08_landmarks()
    idx = np.concatenate([np.atleast_1d(lm[n]) for n in SHOULDER_LINE])
    shoulder = float(body.vertices[idx, 2].mean())
    armpit = float(base_levels(body)["armpit"])
    dz = 0.02
    target = _shoulders_raised(body, dz, armpit + 0.01, float(body.vertices[idx, 2].min()))
    zmap = with_shoulder_line(level_map(body, target), body, target)
    moved = map_height(np.array([armpit, shoulder, shoulder + 0.1]), *zmap) - [armpit, shoulder, shoulder + 0.1]
    assert moved[0] == pytest.approx(0.0, abs=1e-3)
    assert moved[1] == pytest.approx(dz, abs=1e-6)
    assert moved[2] == pytest.approx(dz, abs=1e-3)     # above the shoulders: moved, not stretched
    # without the knot, the armpit-to-crown segment spread the growth up into the head
    plain = map_height(np.array([shoulder]), *level_map(body, target))[0] - shoulder
    assert plain < 0.5 * dz


def _landmarks_moved(body, names, lo: float, hi: float, dz: float):
    """(the body with the named MakeHuman landmarks' band moved dz up, tapering to nothing at
    lo and hi, the landmarks' mean height before)."""
    from seamfit.body.shape_model import hm08_landmarks
    lm = hm08_landmarks()
    idx = np.concatenate([np.atleast_1d(np.asarray(lm[n])) for n in names])
    zl = body.vertices[idx, 2]
    v = np.array(body.vertices, dtype=float)
    z = v[:, 2]
    v[:, 2] = z + dz * np.clip(np.minimum((z - lo) / (zl.min() - lo), (hi - z) / (hi - zl.max())), 0.0, 1.0)
    return replace(body, vertices=v), float(zl.mean())


def test_a_darted_bodice_follows_the_bust_point_and_a_skirt_does_not(skirt):
    # A bodice shaped by darts is drafted around the bust point: the height map gets a knot
    # there, where the same landmark vertices are on the target. A bust 1.5 cm lower, with
    # the waist and armpit where they were, moves that level by 1.5 cm; the map of the
    # sections alone leaves it in place.
    from seamfit.body import load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.opt.level_scale import (BUST_POINT, base_levels, darted_above_the_waist, level_map,
                                         map_height, with_bust_point)
    from seamfit.pattern import load_pattern
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    lv = base_levels(body)
    bodice = build_sewn_mesh(load_pattern(SAMPLES / "patterns/fs_bodice/size06/pattern.json"), edge_length_cm=4.0)
    assert darted_above_the_waist(bodice, bodice.x0, lv)
    mesh, xbar, _, _ = skirt
    assert not darted_above_the_waist(mesh, xbar, lv)     # its darts end below the waist
    dz = -0.015
    target, bust = _landmarks_moved(body, BUST_POINT, lv["waist"] + 0.01, lv["armpit"] - 0.01, dz)
    plain = level_map(body, target)
    moved = map_height(np.array([bust]), *with_bust_point(plain, body, target))[0] - bust
    assert moved == pytest.approx(dz, abs=1e-6)
    assert abs(map_height(np.array([bust]), *plain)[0] - bust) < 0.2 * abs(dz)


def test_a_flare_hangs_from_the_natural_waist_and_a_pencil_skirt_does_not(skirt):
    # A skirt the hip does not hold (a circle skirt) hangs from the waist tape: the height
    # map gets a knot at MakeHuman's waist ring, where its vertices are on the target. A
    # waist 1.5 cm lower, with the crotch and armpit in place, moves that level 1.5 cm.
    from seamfit.body import load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.opt.grade import base_drape
    from seamfit.opt.level_scale import (NATURAL_WAIST, base_levels, level_map, level_scaled_pattern,
                                         map_height, with_natural_waist)
    from seamfit.pattern import load_pattern
    from seamfit.sim.model import Fabric, SimSettings
    mesh, xbar, body, sdf = skirt
    target = load_body(SAMPLES / "bodies/women_size10.obj")
    _, info = level_scaled_pattern(mesh, xbar, body, target, sdf, return_info=True)
    assert info["seat_line"] and not info["natural_waist"]
    circle = load_pattern(SAMPLES / "patterns/gc_circle_skirt/size06/pattern.json")
    cmesh = build_sewn_mesh(circle, edge_length_cm=4.0)
    cx, _ = base_drape(cmesh, circle, body, sdf, Fabric(), SimSettings())
    _, info = level_scaled_pattern(cmesh, cx, body, target, sdf, return_info=True)
    assert info["natural_waist"] and not info["seat_line"]
    lv = base_levels(body)
    dz = -0.015
    lower, waist = _landmarks_moved(body, NATURAL_WAIST, lv["crotch"] + 0.01, lv["armpit"] - 0.01, dz)
    moved = map_height(np.array([waist]), *with_natural_waist(level_map(body, lower), body, lower))[0] - waist
    assert moved == pytest.approx(dz, abs=1e-6)


def test_at_the_crotch_a_sliver_round_the_axis_is_no_torso():
    # Where the legs part, the loop round the body's axis can be a sliver between them; the
    # cloth nearest it once made a 5 cm "girth" and a trouser's crotch level a stretch of 4.6.
    from seamfit.body import load_body
    from seamfit.body.measure import _Slicer, body_measurements
    from seamfit.opt.fit import torso_cloth
    from seamfit.opt.level_scale import _enclosed_growth, _hull, _hull_perimeter
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    crotch = body_measurements(body)["levels_z_m"]["crotch"]
    s = _Slicer(body)
    sliver = None
    for z in np.arange(crotch - 0.01, crotch + 0.01, 0.0005):
        ids = s.torso_ids(z)
        others = [i for i in s.loop_ids(z) if not np.isin(i, ids).any()]
        pts = s.cut(z)[3]
        if len(ids) >= 3 and others and max(_hull_perimeter(_hull(pts[i])) for i in others
                                            if len(i) >= 3) > _hull_perimeter(_hull(pts[ids])):
            sliver = z
            break
    assert sliver is not None, "the sample body has a sliver at its crotch"
    pts = s.cut(sliver)[3]
    # one section round both legs, and the crotch seam's cloth against the sliver
    trousers_top = np.vstack([_ring_around(pts, 0.01), _ring_around(pts[s.torso_ids(sliver)], 0.003)])
    assert torso_cloth(s, sliver, pts, trousers_top) is None
    g, h0, h1 = _enclosed_growth(s, body.vertices, sliver, trousers_top)
    assert g == pytest.approx(_hull_perimeter(_hull(trousers_top)), rel=1e-9)
    assert h0 > 0.5 * g and h1 == pytest.approx(h0, rel=1e-12)


def _longer_waist_to_hip(body, dz: float):
    """The body with dz more between its seat and its natural waist: every vertex above the
    seat moves up, by dz from the waist up; nothing grows around."""
    from seamfit.body.measure import body_measurements
    from seamfit.body.shape_model import hm08_landmarks
    lv = body_measurements(body, landmarks=hm08_landmarks())["levels_z_m"]
    v = np.array(body.vertices, dtype=float)
    lo, hi = lv["hip"] + 0.01, lv["waist"] - 0.01
    v[:, 2] += dz * np.clip((v[:, 2] - lo) / (hi - lo), 0.0, 1.0)
    return replace(body, vertices=v)


def _skirt_lengths_cm(mesh, xbar, p, seat_z):
    """Per skirt panel, (waist to seat, seat to hem) down the pattern (cm), the seat line
    being the pattern points that hang at the base body's seat."""
    vp = np.asarray(mesh.vertex_panel)
    out = []
    for i, name in enumerate(mesh.panel_names):
        if not name.startswith("skirt"):
            continue
        on = vp == i
        v = 100.0 * p[on, 1]
        seat = v[np.abs(xbar[on, 2] - seat_z) < 0.015].mean()
        out.append((v.max() - seat, seat - v.min()))
    return np.array(out)


def test_a_skirt_s_seat_line_moves_with_the_body_s_waist_to_hip(skirt):
    # Skirts are drafted down from the waist: the seat line sits the body's waist-to-hip
    # below it. A body longer there by 3 cm, and no taller below the seat, gets a skirt
    # 3 cm longer above the seat line and as long below it.
    from seamfit.body.measure import body_measurements
    from seamfit.body.shape_model import hm08_landmarks
    from seamfit.opt.level_scale import level_scaled_pattern
    mesh, xbar, body, sdf = skirt
    target = _longer_waist_to_hip(body, 0.03)
    m0 = body_measurements(body, landmarks=hm08_landmarks())
    m1 = body_measurements(target, landmarks=hm08_landmarks())
    assert m1["waist_to_hip"] - m0["waist_to_hip"] == pytest.approx(3.0, abs=0.2)
    seat_z = m0["levels_z_m"]["waist"] - 0.01 * m0["waist_to_hip"]
    before = _skirt_lengths_cm(mesh, xbar, 0.01 * np.asarray(mesh.uv_cm), seat_z)
    after = _skirt_lengths_cm(mesh, xbar, level_scaled_pattern(mesh, xbar, body, target, sdf), seat_z)
    grow = after - before
    assert np.all(np.abs(grow[:, 0] - 3.0) < 0.6), grow
    assert np.all(np.abs(grow[:, 1]) < 0.4), grow


def test_a_body_of_another_mesh_keeps_the_height_map():
    # The seat line needs the landmark-based waist-to-hip, which only the MakeHuman
    # mesh's landmarks give; any other mesh keeps the map of its sections.
    from seamfit.body import load_body
    from seamfit.opt.level_scale import (level_map, with_bust_point, with_natural_waist, with_seat_line,
                                         with_shoulder_line)
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    other = replace(body, faces=np.asarray(body.faces)[::-1].copy())
    zmap = level_map(other, other)
    out = with_seat_line(zmap, other, other)
    assert out is zmap
    assert with_shoulder_line(zmap, other, other) is zmap
    assert with_bust_point(zmap, other, other) is zmap
    assert with_natural_waist(zmap, other, other) is zmap


def test_a_level_through_the_waist_opening_stretches_as_the_waist_below_it(skirt):
    # The waistline is not level: the levels it crosses cut part of the section (the sides
    # without the centre, or the reverse). They are no girth and take the stretch of the
    # nearest level that is, so the waist edge grows as the waist does, and not as a few
    # points of the body the part-section happens to enclose.
    from seamfit.opt.level_scale import CLOSED_FRACTION, cloth_length, girth_profile, openings
    mesh, xbar, body, sdf = skirt
    prof = girth_profile(mesh, xbar, body, _widened(body, 1.06), sdf)
    z, G, sx = prof["z"], prof["G"], prof["sx"]
    top = int(np.flatnonzero(np.isfinite(G))[-1])
    assert top < len(z) - 1, "the waistline crosses the top levels"
    tri = np.asarray(mesh.triangles)
    around = openings(mesh, xbar)
    for k in range(top + 1, len(z)):
        za, zb = xbar[around[:, 0], 2] - z[k], xbar[around[:, 1], 2] - z[k]
        assert np.any(za * zb < 0), "a level without a girth crosses an opening"
        assert cloth_length(xbar, tri, z[k]) < CLOSED_FRACTION * G[top], "part of a section"
    assert np.allclose(sx[top:], sx[top])
    assert sx[top] > 1.03          # the widened body's waist grew 6 %, less the ease


def test_openings_are_the_waist_and_hem_not_the_side_seams(skirt):
    from seamfit.opt.level_scale import openings
    mesh, xbar, _, _ = skirt
    e = openings(mesh, xbar)
    z = xbar[e].mean(axis=1)[:, 2]
    zmin, zmax = xbar[:, 2].min(), xbar[:, 2].max()
    near_edge = np.minimum(z - zmin, zmax - z) < 0.05
    assert len(e) > 0 and near_edge.all()
    pairs = set(map(tuple, np.sort(np.asarray(mesh.sewing_pairs), axis=1)))
    assert not any(tuple(sorted(x)) in pairs for x in e)


def _band(x0: float, x1: float, y: float, z: float, n: int = 4):
    """n triangles (n, 3, 3) of 1 cm strips across x0..x1 at depth y, around height z."""
    xs = np.linspace(x0, x1, n + 1)
    return np.array([[[a, y, z - 0.004], [b, y, z - 0.004], [a, y, z + 0.004]] for a, b in zip(xs[:-1], xs[1:])])


def test_a_darted_front_grows_between_its_bust_points_as_the_span_did():
    # Both drafting systems place a bodice's dart apexes from the bust span and give the
    # rest of the front's growth to the side: at the bust, the cloth between the bust points
    # stretches by the span's ratio, the rest of the front takes what is left of the front's
    # growth, and the back is untouched. Above the armpit and below the hip nothing changes.
    from seamfit.opt.level_scale import _bust_span_split
    span = {"points": np.array([[0.09, -0.10, 1.22], [-0.09, -0.10, 1.22]]), "ratio": 1.02,
            "y_mid": 0.0, "hip": 0.80, "waist": 1.00, "armpit": 1.25}
    z = 1.10                                        # between the waist and the bust point
    inner, outer = _band(-0.08, 0.08, -0.12, z), _band(0.10, 0.20, -0.06, z)
    back = _band(-0.2, 0.2, 0.08, z)
    high, low = _band(-0.08, 0.08, -0.12, 1.30), _band(-0.08, 0.08, -0.12, 0.70)
    X = np.concatenate([inner, outer, back, high, low])
    sx = np.full(len(X), 1.10)
    out = _bust_span_split(sx, X, span)
    k = np.cumsum([0, len(inner), len(outer), len(back), len(high), len(low)])
    width = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1) / np.ptp(X[:, :, 2], axis=1)
    assert np.allclose(out[k[0]:k[1]], 1.02)
    front = slice(k[0], k[2])           # the front's girth grows as much as before
    assert np.sum(width[front] * (out[front] - 1)) == pytest.approx(np.sum(width[front] * (sx[front] - 1)))
    assert np.all(out[k[1]:k[2]] > 1.10)
    assert np.array_equal(out[k[2]:], sx[k[2]:])   # the back, above the armpit, below the hip


def test_the_bust_span_is_read_from_the_landmarks_of_both_bodies():
    from seamfit.body import load_body
    from seamfit.body.shape_model import hm08_landmarks
    from seamfit.opt.level_scale import BUST_POINT, base_levels, bust_span
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    lv = base_levels(body)
    idx = [int(np.atleast_1d(hm08_landmarks()[n])[0]) for n in BUST_POINT]
    v = np.array(body.vertices, dtype=float)
    d0 = np.linalg.norm(v[idx[0]] - v[idx[1]])
    v[idx[0], 0] += 0.01 * np.sign(v[idx[0], 0])    # one bust point 1 cm further out
    span = bust_span(body, replace(body, vertices=v), lv)
    assert span["ratio"] == pytest.approx(np.linalg.norm(v[idx[0]] - v[idx[1]]) / d0)
    assert span["ratio"] > 1.0
    other = replace(body, faces=np.asarray(body.faces)[::-1].copy())
    assert bust_span(other, other, lv) is None


def _row_growths(mesh, xbar, p, S, E2, across, rows_mask):
    """Per (panel, 1 cm level) row in ``rows_mask``: (the growth across the target S asks,
    the growth the pattern p makes), area-weighted over the row's triangles."""
    from seamfit.opt.level_scale import LEVEL_STEP_M
    tri = np.asarray(mesh.triangles)
    z = xbar[tri].mean(axis=1)[:, 2]
    row = np.floor(z / LEVEL_STEP_M).astype(np.int64) * 100 + np.asarray(mesh.vertex_panel)[tri[:, 0]]
    area = 0.5 * np.abs(np.linalg.det(E2))
    P = p[tri]
    J = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2) @ np.linalg.inv(E2)
    got = np.linalg.norm(np.einsum("tij,tj->ti", J, across), axis=1) - 1.0
    want = np.einsum("ti,tij,tj->t", across, S, across) - 1.0
    out = []
    for r in np.unique(row[rows_mask]):
        m = rows_mask & (row == r)
        out.append((float(area[m] @ want[m]), float(area[m] @ got[m])))
    return np.array(out)


def test_each_supported_level_grows_by_what_the_body_grew_there(skirt):
    """The hip grown 10 % and the waist not: the rows between want different stretches, no
    pattern has them all, and the plain fit settles between them, about 5 % short of each
    row's growth. Held, each panel's row at a level the body supports comes within about
    1 % of its growth, and all of them together within half a per cent."""
    from seamfit.body.measure import body_measurements
    from seamfit.opt.level_scale import (LEVEL_STEP_M, _gradient_solver, _held_girths,
                                         _stretch_targets, girth_profile, level_map)
    mesh, xbar, body, sdf = skirt
    lv = body_measurements(body)["levels_z_m"]
    target = _grown_between(body, 1.10, lv["hip"], lv["waist"])
    prof = girth_profile(mesh, xbar, body, target, sdf)
    S, E2, across, on_arm = _stretch_targets(mesh, xbar, prof, level_map(body, target))

    solve = _gradient_solver(mesh, E2)

    tri = np.asarray(mesh.triangles)
    z = xbar[tri].mean(axis=1)[:, 2]
    zs = prof["z"][prof["supported"]]
    assert len(zs) > 3
    at = np.min(np.abs(z[:, None] - zs[None, :]), axis=1) <= 0.5 * LEVEL_STEP_M
    plain = _row_growths(mesh, xbar, solve(S), S, E2, across, at)
    held = _row_growths(mesh, xbar, solve(_held_girths(mesh, xbar, S, E2, across, on_arm, prof, solve)),
                        S, E2, across, at)
    # The rows that grow (the waist's barely does, so its relative miss means little).
    big = np.abs(plain[:, 0]) > 0.25 * np.max(np.abs(plain[:, 0]))
    assert big.sum() > 10
    miss_plain = np.median(np.abs(plain[big, 1] / plain[big, 0] - 1.0))
    miss_held = np.median(np.abs(held[big, 1] / held[big, 0] - 1.0))
    assert miss_plain > 0.03
    assert miss_held < 0.02 and miss_held < 0.5 * miss_plain
    assert abs(plain[big, 1].sum() / plain[big, 0].sum() - 1.0) > 0.01
    assert abs(held[big, 1].sum() / held[big, 0].sum() - 1.0) < 0.005
