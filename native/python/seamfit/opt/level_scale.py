"""Measurement-aware start: the base pattern stretched, level by level, by how much the
body grew there (docs/method.md, "Level scaling").

Drafting systems hold the ease at each tape-measure level: a garment girth grows by what
the body girth it encloses grew, and lengths follow the body's landmark heights. Read off
the base garment draped on the base body (x-bar), that gives every triangle of the pattern
a target stretch:

* around the body (across the pattern's "down", the vertical pulled back into the
  pattern through the drape), by sx(z) = 1 + dH(z) / G(z): G is the garment's tape girth at the
  triangle's height z on the base body, dH how much the body girth the garment encloses
  grew between the bodies. Additive, as ease is: a circle skirt's hem grows by the waist's
  change, not in proportion to it;
* across that direction, by sy(z), the slope at z of the piecewise linear map that takes
  the base body's levels (soles, crotch, waist, armpit, crown) to where the same body
  sections are on the target, and the shoulder line (and, for a bodice shaped by darts,
  the bust point) to where its landmarks went; a skirt the seat holds also has its seat
  line the target's waist-to-hip below the target's waist, and a flare (a skirt the seat does
  not hold) a knot at the natural waist it hangs from.

dH is measured where most of the garment's girth rests on the body; between two such
levels it is interpolated, and where the garment hangs free (a skirt below the seat, a
flare below the waist) it is the growth of the level it hangs from. A level that cuts an
opening's edge (a waistline rising to the side seams, a dipping hem) and finds less cloth
than its tape is part of a section, no girth: it stretches as the nearest level that is
one. Sleeves are measured around the arm instead (seamfit.opt.sleeves). A waist dart takes
up what the girth at its tip grew beyond the girth at its open end: its wedge joins the fit
with the across-stretch that lets the panel's row at the open end grow as the tip's row did
(_dart_wedges). A bodice shaped by darts grows, across its front, between the bust points
as the bust span did (both drafting systems place the dart apexes from it) and beside them by
the rest of the front's growth (_bust_span_split). The pattern whose
triangle gradients best match those stretches (a
sparse least-squares solve per panel, the same kind of solve as a Poisson problem) is the
level-scaled pattern. The stretches of neighbouring levels are no pattern together, so the
fit settles between them; at each level the body supports, each panel's row then has its
across-stretch corrected by what the fit missed of its growth (_held_girths), so the ease
there is held. Equal bodies give the base pattern back exactly.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from ..body.measure import _Slicer, body_measurements
from ..body.shape_model import landmarks_of
from .costs import sample_sdf
from .fit import hull as _hull
from .fit import mesh_cross_section, outside_by, torso_cloth
from .sleeves import sleeve_targets

# A garment vertex this close to the body (m) is held by it (the drape rests on the
# contact barrier, about 1-3 mm out; hanging cloth is centimetres away).
CONTACT_M = 0.005
LEVEL_STEP_M = 0.01     # girth profile sampling
# A level is supported by the body when at least this share of the garment's vertices
# there touch it: most of its girth rests on the body.
SUPPORT_FRACTION = 0.5
# A level that crosses an opening's edge (a waistline curving up to the side seams, a
# dipping hem) is a girth only where its cloth covers at least this share of its tape: a
# vent's small gap still measures the level, a section that misses the centre front does not.
CLOSED_FRACTION = 0.9
# An opening runs around the body (waist, hem) when it climbs less than this per length.
OPENING_SLOPE = 0.5
# A dart's open end lies on the panel's row of vertices this close to it along the dart (m).
DART_ROW_M = 0.015
# A dart's wedge stretches across by at least a fifth (its legs never meet: the outline
# stays simple) and at most five times.
DART_STRETCH = (0.2, 5.0)
# A supported level's growth is held against the gradient fit's compromise in this many
# corrections, each scaling a panel's row's across-stretch by at most these factors.
HOLD_ROUNDS = 3
HOLD_FACTOR = (0.5, 2.0)


def base_levels(base_body) -> dict:
    """The base body's measuring levels (z, metres): crotch, hip, waist, bust, armpit."""
    return body_measurements(base_body)["levels_z_m"]


def measure_ahead(base_body, target_body) -> None:
    """Take the measurements level scaling will ask for (each body's levels, and with
    MakeHuman's landmarks its waist-to-hip), so they are remembered when it does: run on
    seamfit.preload's thread while the body fields are built."""
    lm = landmarks_of(base_body, target_body)
    for body in (base_body, target_body):
        body_measurements(body)
        if lm is not None:
            body_measurements(body, landmarks=lm)


def level_map(base_body, target_body, *, crotch: bool = True, levels: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Knots (z_base, z_target) of the monotone piecewise linear map between the two
    bodies' levels: soles, crotch (unless ``crotch`` is False), waist, armpit, crown.

    The levels are found on the base body only. Each one's height on the target is where
    the same body section went: the mean height of the base section's edge crossings
    placed on the target's vertices (both bodies share one mesh topology). A level found
    on each body by its own rule can land elsewhere on the body: the narrowest girth, taken
    for the waist, sits under the bust of a body with a full belly."""
    levels = levels or base_levels(base_body)
    s0 = _Slicer(base_body)
    tv = np.asarray(target_body.vertices, dtype=float)
    zb = [float(base_body.vertices[:, 2].min())]
    zt = [float(tv[:, 2].min())]
    for name in (["crotch"] if crotch else []) + ["waist", "armpit"]:
        a, b, t, _ = s0.cut(levels[name])
        if len(a) < 3:
            continue
        zb.append(float(levels[name]))
        zt.append(float(np.mean(tv[a, 2] + t * (tv[b, 2] - tv[a, 2]))))
    zb.append(float(base_body.vertices[:, 2].max()))
    zt.append(float(tv[:, 2].max()))
    return _monotone(np.array(zb), np.array(zt))


def _with_knot(zmap, kb: float, kt: float):
    """The height map with one more knot, base height kb placed at kt on the target."""
    zb, zt = zmap
    order = np.argsort(np.append(zb, kb), kind="stable")
    return _monotone(np.append(zb, kb)[order], np.append(zt, kt)[order])


def with_seat_line(zmap, base_body, target_body):
    """The height map with a knot at the base body's seat line (its natural waist less its
    waist-to-hip), placed on the target at the target's natural waist (where the map takes
    the base's) less the target's own waist-to-hip. Both lengths are the landmark-based
    measurement of any body of the MakeHuman (hm08) mesh; other bodies keep the map as it is."""
    lm = landmarks_of(base_body, target_body)
    if lm is None:
        return zmap
    m0 = body_measurements(base_body, landmarks=lm)
    m1 = body_measurements(target_body, landmarks=lm)
    waist = float(m0["levels_z_m"]["waist"])
    kb = waist - 0.01 * float(m0["waist_to_hip"])
    kt = float(map_height(np.array([waist]), *zmap)[0]) - 0.01 * float(m1["waist_to_hip"])
    return _with_knot(zmap, kb, kt)


def _landmark_vertices(lm: dict, names) -> np.ndarray:
    """The vertex ids of the named MakeHuman landmarks (a ring counts all its vertices)."""
    return np.concatenate([np.atleast_1d(np.asarray(lm[n])) for n in names])


def _landmark_knot(zmap, base_body, target_body, names):
    """The height map with a knot at the mean height of the named MakeHuman landmarks (a
    ring counts all its vertices), placed where the same vertices are on the target. Bodies
    of another mesh than MakeHuman's (hm08) keep the map as it is."""
    lm = landmarks_of(base_body, target_body)
    if lm is None:
        return zmap
    idx = _landmark_vertices(lm, names)
    kb = float(np.asarray(base_body.vertices)[idx, 2].mean())
    kt = float(np.asarray(target_body.vertices)[idx, 2].mean())
    return _with_knot(zmap, kb, kt)


SHOULDER_LINE = ("neck_side_L", "neck_side_R", "shoulder_point_L", "shoulder_point_R")
NATURAL_WAIST = ("waist_ring",)
BUST_POINT = ("bust_point_L", "bust_point_R")


def with_shoulder_line(zmap, base_body, target_body):
    """A knot at the shoulder line (both ends of both shoulder seams). The head does not
    grow with the size, so between the armpit and the crown a fuller body's growth is all
    below the shoulders: drafts deepen the armhole by it."""
    return _landmark_knot(zmap, base_body, target_body, SHOULDER_LINE)


def with_natural_waist(zmap, base_body, target_body):
    """A knot at the natural waist (MakeHuman's waist ring): a flare hangs from the waist
    tape, where the drafts put its waistline."""
    return _landmark_knot(zmap, base_body, target_body, NATURAL_WAIST)


def with_bust_point(zmap, base_body, target_body):
    """A knot at the bust points: a bodice shaped by darts is drafted around the bust
    point, at which its darts aim."""
    return _landmark_knot(zmap, base_body, target_body, BUST_POINT)


def darted_above_the_waist(mesh, xbar, levels: dict) -> bool:
    """Whether a dart of the garment (a stitch of one panel to itself, from a tip) has its
    tip between the waist and the armpit on the base drape: a bodice shaped to the bust. A
    loose top has none, and its drafts do not follow the bust point."""
    lo, hi = float(levels["waist"]), float(levels["armpit"])
    for k, st in enumerate(mesh.stitches):
        if st.panel_a != st.panel_b:
            continue
        pr = np.asarray(mesh.stitch_pairs[k]).reshape(-1, 2)
        tips = pr[pr[:, 0] == pr[:, 1], 0]
        if np.any((xbar[tips, 2] > lo) & (xbar[tips, 2] < hi)):
            return True
    return False


def _monotone(zb, zt):
    """Only the knots that rise on both bodies, so the map stays monotone."""
    keep = [0]
    for k in range(1, len(zb)):
        if zb[k] > zb[keep[-1]] + 1e-3 and zt[k] > zt[keep[-1]] + 1e-3:
            keep.append(k)
    return zb[keep], zt[keep]


def map_height(z, zb, zt):
    """The level map at heights z: piecewise linear through the knots, and continued with
    the end segments' slopes beyond them. A floor-length garment hangs below the soles (the
    drape has no floor); clamping there would give its hem a zero vertical stretch."""
    z = np.asarray(z, dtype=float)
    out = np.interp(z, zb, zt)
    lo, hi = z < zb[0], z > zb[-1]
    out[lo] = zt[0] + (z[lo] - zb[0]) * (zt[1] - zt[0]) / (zb[1] - zb[0])
    out[hi] = zt[-1] + (z[hi] - zb[-1]) * (zt[-1] - zt[-2]) / (zb[-1] - zb[-2])
    return out


def passes_crotch_as_one_tube(mesh, xbar, base_body, levels: dict | None = None) -> bool:
    """Whether the garment hangs past the crotch closed around both legs (a skirt, a
    dress): its length then follows the waist, not the crotch it never meets; trousers
    fork at the crotch and a top ends above it."""
    crotch_z = float((levels or base_levels(base_body))["crotch"])
    bottom = float(np.min(xbar[:, 2]))
    if bottom > crotch_z - 2 * LEVEL_STEP_M:
        return False
    # Halfway down from the crotch, trouser legs are two tubes, a skirt is one.
    return section_loops(mesh, xbar, 0.5 * (crotch_z + bottom)) == 1


def section_loops(mesh, x, z: float) -> int:
    """How many closed pieces the garment's section at height z has: the triangles that
    straddle z, joined through their vertices and through the stitches (the panels are
    separate pieces of cloth sewn together). Read off the mesh, not off where the cloth
    hangs: wide trouser legs touch each other between the thighs but stay two tubes."""
    tri = np.asarray(mesh.triangles)
    zt = np.asarray(x, dtype=float)[tri, 2] - z
    cut = tri[(zt.min(axis=1) < 0) & (zt.max(axis=1) > 0)]
    return _pieces(cut, np.asarray(mesh.sewing_pairs, dtype=np.int64).reshape(-1, 2), len(x))


def _pieces(cut, pairs, n: int) -> int:
    """How many pieces the triangles ``cut`` (of a mesh of n vertices) and the stitches
    ``pairs`` between their vertices make: section_loops once the cut triangles are known.
    Only the cut triangles' vertices enter the graph."""
    if len(cut) == 0:
        return 0
    used = np.zeros(n, dtype=bool)
    used[cut.ravel()] = True
    pairs = pairs[used[pairs[:, 0]] & used[pairs[:, 1]]]
    node = np.cumsum(used) - 1                  # the used vertices, numbered in order
    edges = node[np.vstack([cut[:, [0, 1]], cut[:, [1, 2]], pairs])]
    m = int(node[-1]) + 1
    g = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(m, m))
    return int(connected_components(g, directed=False)[0])


def openings(mesh, x) -> np.ndarray:
    """(E, 2) the edges of the garment's openings the body passes through lengthwise
    (waist, hem, neckline, cuffs): runs of panel boundary no stitch closes that go more
    around than up, by ``x``. An armhole's edge climbs the side and is left out: a level
    through it still goes round the chest."""
    pairs = np.asarray(mesh.sewing_pairs, dtype=np.int64).reshape(-1)
    sewn = np.zeros(len(mesh.uv_cm), dtype=bool)
    sewn[pairs] = True
    x = np.asarray(x, dtype=float)
    out = []
    for loop in mesh.boundary_loops:
        loop = np.asarray(loop, dtype=np.int64)
        e = np.column_stack([loop, np.roll(loop, -1)])
        free = ~(sewn[e[:, 0]] & sewn[e[:, 1]])
        if free.all():
            runs = [e]
        else:
            # start on a stitched edge; each run of free edges follows one
            k0 = int(np.flatnonzero(~free)[0])
            e, free = np.roll(e, -k0, axis=0), np.roll(free, -k0)
            runs = [r[1:] for r in np.split(e, np.flatnonzero(~free)[1:]) if len(r) > 1]
        for r in runs:
            around = np.linalg.norm(x[r[:, 1], :2] - x[r[:, 0], :2], axis=1).sum()
            up = np.ptp(x[r.ravel(), 2])
            if up < OPENING_SLOPE * around:
                out.append(r)
    return np.vstack(out) if out else np.zeros((0, 2), dtype=np.int64)


def cloth_length(x, triangles, z: float) -> float:
    """Length of the garment's section at height z: the cloth itself, folds included."""
    X = np.asarray(x, dtype=float)[np.asarray(triangles)]
    d = X[:, :, 2] - z
    crossed, points = [], []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        da, db = d[:, a], d[:, b]
        c = da * db < 0
        t = np.where(c, da / np.where(c, da - db, 1.0), 0.0)
        crossed.append(c)
        points.append(X[:, a, :2] + t[:, None] * (X[:, b, :2] - X[:, a, :2]))
    crossed, points = np.stack(crossed, 1), np.stack(points, 1)
    two = crossed.sum(axis=1) == 2
    seg = points[two][crossed[two]].reshape(-1, 2, 2)
    return float(np.linalg.norm(seg[:, 0] - seg[:, 1], axis=1).sum())


def _crosses(x, edges, z: float) -> bool:
    za, zb = x[edges[:, 0], 2] - z, x[edges[:, 1], 2] - z
    return bool(np.any(za * zb < 0))


def _hull_perimeter(h) -> float:
    p = h.points[h.vertices]
    return float(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1).sum())


def _enclosed_growth(slicer: _Slicer, target_v: np.ndarray, z: float, garment_pts: np.ndarray):
    """(garment tape girth at z, tape girth of the body section inside the garment's hull,
    that section's girth on the target body): the target's section is the same edge
    crossings on the target's vertices (both bodies share one mesh topology, as the
    transfer of Eq. 15 needs), so no level has to be matched. NaN where missing."""
    if len(garment_pts) < 3:
        return np.nan, np.nan, np.nan
    hg = _hull(garment_pts)
    if hg is None:
        return np.nan, np.nan, np.nan
    a, b, t, pts = slicer.cut(z)
    torso = torso_cloth(slicer, z, pts, garment_pts)
    if torso is not None:
        ids, garment_pts, hg = torso
        a, b, t, pts = a[ids], b[ids], t[ids], pts[ids]
    g = _hull_perimeter(hg)
    if len(pts) < 3:
        return g, np.nan, np.nan
    # A body point up to contact distance outside the cloth's hull is under the cloth: the
    # flat triangles of a coarse mesh cut chords through a convex part (a bust, a thigh), and
    # the points they leave out are the ones that grow the tape most.
    inside = outside_by(hg, pts) <= CONTACT_M
    if inside.sum() < 3:
        return g, np.nan, np.nan
    a, b, t = a[inside], b[inside], t[inside]
    q = target_v[a, :2] + t[:, None] * (target_v[b, :2] - target_v[a, :2])
    h0, h1 = _hull(pts[inside]), _hull(q)
    if h0 is None or h1 is None:
        return g, np.nan, np.nan
    return g, _hull_perimeter(h0), _hull_perimeter(h1)


def girth_profile(mesh, xbar, base_body, target_body, base_sdf, levels: dict | None = None,
                  skip=None) -> dict:
    """Per level z of the base garment: G (garment girth), dH (growth of the enclosed body
    girth where the body supports the garment, interpolated between such levels and taken
    from the nearest one where the garment hangs) and sx = 1 + dH / G. Triangles in the
    mask ``skip`` (sleeves, graded around the arm) are not part of any level."""
    tri = np.asarray(mesh.triangles)
    own = np.ones(len(xbar), dtype=bool)
    if skip is not None and np.any(skip):
        tri = tri[~np.asarray(skip)]
        own[:] = False
        own[tri.ravel()] = True
    s0 = _Slicer(base_body)
    tv = np.asarray(target_body.vertices, dtype=float)
    zmin, zmax = float(xbar[:, 2].min()), float(xbar[:, 2].max())
    zs = np.arange(zmin + 0.5 * LEVEL_STEP_M, zmax, LEVEL_STEP_M)
    if len(zs) == 0:
        zs = np.array([0.5 * (zmin + zmax)])
    phi = sample_sdf(base_sdf, xbar)[0]
    G = np.full(len(zs), np.nan)
    dH = np.full(len(zs), np.nan)
    around = openings(mesh, xbar)
    around = around[own[around[:, 0]] & own[around[:, 1]]] if len(around) else around
    # Each level's section comes from the triangles that straddle it (lowest vertex below
    # z, highest above), taken in mesh order: the same points in the same order as from
    # all triangles, without going over the whole mesh three times a level.
    tz = xbar[tri, 2]
    tlo, thi = tz.min(axis=1), tz.max(axis=1)
    for k, z in enumerate(zs):
        at = tri[(tlo < z) & (thi > z)]
        g0, h0, h1 = _enclosed_growth(s0, tv, z, mesh_cross_section(xbar, at, z))
        if (np.isfinite(g0) and _crosses(xbar, around, z)
                and cloth_length(xbar, at, z) < CLOSED_FRACTION * g0):
            continue                    # part of a section: no girth (CLOSED_FRACTION)
        G[k] = g0
        # The body sets a level's girth where most of the garment's section rests on it;
        # where a few points graze it (a flare touching the seat) the garment hangs.
        band = own & (np.abs(xbar[:, 2] - z) < LEVEL_STEP_M)
        if band.any() and np.mean(phi[band] < CONTACT_M) >= SUPPORT_FRACTION and np.isfinite(h1):
            dH[k] = h1 - h0
    supported = np.isfinite(dH)
    # Below a supported hip, a garment closed around both legs (its section is one loop:
    # a skirt, a dress) hangs from the hip, as a straight skirt's hem is drafted from the
    # hip; trouser legs follow their own levels.
    hip_z = float((levels or base_levels(base_body))["hip"])
    k_hip = int(np.argmin(np.abs(zs - hip_z)))
    hip_supported = bool(np.isfinite(dH[k_hip]))
    if hip_supported:
        # section_loops at each level below the hip, over the whole mesh (sleeves too)
        all_tri = np.asarray(mesh.triangles)
        az = xbar[all_tri, 2]
        alo, ahi = az.min(axis=1), az.max(axis=1)
        pairs = np.asarray(mesh.sewing_pairs, dtype=np.int64).reshape(-1, 2)
        for k in range(k_hip):
            if _pieces(all_tri[(alo < zs[k]) & (ahi > zs[k])], pairs, len(xbar)) == 1:
                dH[k] = dH[k_hip]
    known = np.flatnonzero(np.isfinite(dH))
    if len(known) == 0:
        dH[:] = 0.0
    else:
        # Between two supported levels the garment spans from one to the other; above the
        # top one and below the lowest it hangs from the nearest.
        dH = np.interp(zs, zs[known], dH[known])
    ok = np.isfinite(G) & (G > 0)
    sx = np.ones(len(zs))
    if ok.any():
        # A level that is no girth (an opening's edge, or no section) stretches as the
        # nearest one that is.
        sx = np.interp(zs, zs[ok], 1.0 + dH[ok] / G[ok])
    return {"z": zs, "G": G, "dH": dH, "sx": sx, "hip_supported": hip_supported, "supported": supported}


def _stretch_targets(mesh, xbar, profile, zmap, sleeves=None, bust=None):
    """Per triangle the 2x2 target gradient S_t of the new pattern against the base one;
    ``sleeves`` (mask, sx, up) gives sleeve triangles the arm's girth stretch and its
    direction in place of the vertical; ``bust`` (bust_span) splits a darted bodice's front
    growth at its bust points. Returns S, the base pattern's edge matrices E2, each
    triangle's across direction in the pattern (the tape's) and the sleeve triangles' mask."""
    tri = np.asarray(mesh.triangles)
    p = 0.01 * np.asarray(mesh.uv_cm, dtype=float)
    zb, zt = zmap
    X = xbar[tri]                                   # (T, 3, 3)
    P = p[tri]                                      # (T, 3, 2)
    E3 = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]], axis=2)   # (T, 3, 2)
    E2 = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)   # (T, 2, 2)
    F = E3 @ np.linalg.inv(E2)                      # pattern -> 3D, (T, 3, 2)
    c = X.mean(axis=1)
    z = c[:, 2]
    sx = np.interp(z, profile["z"], profile["sx"])
    h = LEVEL_STEP_M
    sy = (map_height(z + h, zb, zt) - map_height(z - h, zb, zt)) / (2 * h)
    # The vertical lies in the cloth's plane wherever it hangs, folds included, so the
    # pattern's "down" is the pullback of the vertical; the tape runs across it.
    n = np.cross(E3[:, :, 0], E3[:, :, 1])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    up = np.tile([0.0, 0.0, 1.0], (len(tri), 1))
    on_arm = np.asarray(sleeves[0], dtype=bool) if sleeves is not None else np.zeros(len(tri), dtype=bool)
    if bust is not None:
        sx[~on_arm] = _bust_span_split(sx[~on_arm], X[~on_arm], bust)
    if on_arm.any():
        _, sx_arm, up_arm = sleeves
        sx = np.where(on_arm, sx_arm, sx)
        up[on_arm] = up_arm[on_arm]
    v3 = up - np.sum(n * up, axis=1, keepdims=True) * n
    FtF = np.einsum("tki,tkj->tij", F, F)
    v2 = np.linalg.solve(FtF, np.einsum("tki,tk->ti", F, v3)[:, :, None])[:, :, 0]
    # Where the cloth lies nearly flat (a shoulder), fall back to the grain: v is the
    # grain, along the body, on every panel.
    weak = np.linalg.norm(v3, axis=1) < 0.3
    v2[weak] = [0.0, 1.0]
    v2 /= np.maximum(np.linalg.norm(v2, axis=1, keepdims=True), 1e-300)
    d = np.column_stack([v2[:, 1], -v2[:, 0]])
    e = np.column_stack([-d[:, 1], d[:, 0]])
    eye = np.eye(2)[None]
    S = eye + (sx - 1)[:, None, None] * np.einsum("ti,tj->tij", d, d) \
        + (sy - 1)[:, None, None] * np.einsum("ti,tj->tij", e, e)
    return S, E2, d, on_arm


def _held_girths(mesh, xbar, S, E2, across, skip, profile, solve):
    """S with each panel's across-stretch at each supported level corrected, HOLD_ROUNDS
    times, by what the gradient fit ``solve`` (S -> pattern) missed of that level's growth.
    The targets of neighbouring levels disagree (their sum is no pattern), so the fit
    settles between them and a panel's row misses a few per cent of what its body grew;
    that is ease lost or gained at a level the body holds. A level the garment hangs at
    keeps the fit's compromise, which is how a flare's drafts grow too."""
    tri = np.asarray(mesh.triangles)
    z = xbar[tri].mean(axis=1)[:, 2]
    zs = profile["z"][profile["supported"]]
    if len(zs) == 0:
        return S
    held = ~np.asarray(skip, dtype=bool) & (np.min(np.abs(z[:, None] - zs[None, :]), axis=1) <= 0.5 * LEVEL_STEP_M)
    if not held.any():
        return S
    # One row per panel and level.
    row = np.floor(z / LEVEL_STEP_M).astype(np.int64) * len(mesh.panel_names) \
        + np.asarray(mesh.vertex_panel)[tri[:, 0]]
    area = 0.5 * np.abs(np.linalg.det(E2))
    dd = np.einsum("ti,tj->tij", across, across)
    want = np.einsum("ti,tij,tj->t", across, S, across) - 1.0
    inv = np.linalg.inv(E2)
    # Each row's triangles in mesh order (a stable sort of the held ones by row).
    ids = np.flatnonzero(held)
    ids = ids[np.argsort(row[ids], kind="stable")]
    rows = np.split(ids, np.flatnonzero(np.diff(row[ids])) + 1)
    rows = [m for m in rows if abs(float(area[m] @ want[m])) >= 1e-3 * float(area[m].sum())]
    scale = np.ones(len(rows))
    S0, S = S, S.copy()
    for _ in range(HOLD_ROUNDS):
        P = solve(S)[tri]
        J = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2) @ inv
        got = np.linalg.norm(np.einsum("tij,tj->ti", J, across), axis=1) - 1.0
        for i, m in enumerate(rows):
            gw, gg = float(area[m] @ want[m]), float(area[m] @ got[m])
            # Only a growth (or shrink) the fit made in the right direction is scaled.
            if not gw * gg > 0:
                continue
            scale[i] = float(np.clip(scale[i] * gw / gg, *HOLD_FACTOR))
            S[m] = S0[m] + (want[m] * (scale[i] - 1.0))[:, None, None] * dd[m]
    return S


def bust_span(base_body, target_body, levels: dict) -> dict | None:
    """What a darted bodice's front is drafted from besides its girths: the bust points (the
    base's, (2, 3)), how much farther apart they are on the target (the span's ratio), the
    torso's middle depth at the bust, and the levels the rule fades between (hip, waist,
    armpit). None for a body of another mesh than MakeHuman's (no bust point landmarks)."""
    lm = landmarks_of(base_body, target_body)
    if lm is None:
        return None
    idx = _landmark_vertices(lm, BUST_POINT)
    v0 = np.asarray(base_body.vertices, dtype=float)
    b0, b1 = v0[idx], np.asarray(target_body.vertices, dtype=float)[idx]
    at_bust = np.abs(v0[:, 2] - b0[:, 2].mean()) < LEVEL_STEP_M
    return {"points": b0, "ratio": float(np.linalg.norm(b1[0] - b1[1]) / np.linalg.norm(b0[0] - b0[1])),
            "y_mid": float(v0[at_bust, 1].mean()),
            "hip": float(levels["hip"]), "waist": float(levels["waist"]), "armpit": float(levels["armpit"])}


def _bust_span_split(sx, X, span: dict) -> np.ndarray:
    """Per triangle the across-stretch with a front's growth split at the bust points: the
    cloth between them (in front of the torso's middle) stretches as the span between the
    bust points did, and the rest of the front at that level takes what that leaves of the
    level's growth of the front, so the front and the back grow as before. Full from the
    waist to the bust point, fading to nothing at the armpit and at the hip.
    X (T, 3, 3) the triangles on the base drape."""
    b0 = span["points"]
    z_bp = float(b0[:, 2].mean())
    c = X.mean(axis=1)
    # What a triangle adds to its level's girth: its width there, area over height.
    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
    width = area / np.maximum(np.ptp(X[:, :, 2], axis=1), 1e-3)
    z = c[:, 2]
    up = (span["armpit"] - z) / max(span["armpit"] - z_bp, LEVEL_STEP_M)
    down = (z - span["hip"]) / max(span["waist"] - span["hip"], LEVEL_STEP_M)
    w = np.clip(np.minimum(up, down), 0.0, 1.0)
    front = c[:, 1] < span["y_mid"]
    between = front & (np.abs(c[:, 0] - b0[:, 0].mean()) < 0.5 * abs(b0[0, 0] - b0[1, 0])) & (w > 0)
    out = np.array(sx, dtype=float)
    level = np.floor(z / LEVEL_STEP_M).astype(np.int64)
    for k in np.unique(level[between]):
        at = level == k
        inner, outer = at & between, at & front & ~between
        if not outer.any():
            continue
        d = w[inner] * (span["ratio"] - out[inner])
        moved = float(np.sum(width[inner] * d))
        out[inner] += d
        out[outer] -= moved / float(np.sum(width[outer]))
    return out


def _gradient_solver(mesh, E2, tri=None):
    """S (T, 2, 2) -> the pattern (N, 2) m whose per-triangle gradient best matches S
    (area-weighted least squares), each panel keeping its centroid. The normal matrix is
    factored once, so the held growth's corrections (_held_girths) cost a solve each."""
    tri = np.asarray(mesh.triangles) if tri is None else tri
    p = 0.01 * np.asarray(mesh.uv_cm, dtype=float)
    n, T = len(p), len(tri)
    area = 0.5 * np.abs(np.linalg.det(E2))
    Dt = np.linalg.inv(E2).transpose(0, 2, 1) @ np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])  # (T, 2, 3)
    w = np.sqrt(area)
    rows = np.repeat(np.arange(2 * T), 3)
    cols = np.repeat(tri, 2, axis=0).ravel()
    vals = (w[:, None, None] * Dt).reshape(-1)
    A = sp.csr_matrix((vals, (rows, cols)), shape=(2 * T, n))
    # Pin one vertex per panel (the problem is translation-invariant per panel).
    vp = np.asarray(mesh.vertex_panel)
    pins = np.array([np.flatnonzero(vp == k)[0] for k in range(len(mesh.panel_names))])
    big = 1e3 * float(w.max())
    Apin = sp.csr_matrix((np.full(len(pins), big), (np.arange(len(pins)), pins)), shape=(len(pins), n))
    M = sp.vstack([A, Apin]).tocsr()
    lu = splu((M.T @ M).tocsc())
    panels = [vp == k for k in range(len(mesh.panel_names))]

    def solve(S):
        B = (w[:, None, None] * S.transpose(0, 2, 1)).reshape(2 * T, 2)  # row (t, j), column c = S[c, j]
        rhs = M.T @ np.vstack([B, big * p[pins]])
        out = lu.solve(np.asarray(rhs))
        for idx in panels:
            out[idx] += p[idx].mean(axis=0) - out[idx].mean(axis=0)
        return out
    return solve


def _darts(mesh, xbar) -> list[dict]:
    """The mesh's vertical darts: a stitch of one panel to itself whose pairs run from one
    tip (a vertex paired with itself) to the open end, and whose open end lies above or
    below its tip on the base drape (a waist dart; a bust dart from the side seam runs
    across the body and is left out). Per dart: tip, the two legs' vertices from the tip
    out, the across and along directions in the pattern, the intake at the open end (m)
    and the heights of the open end and the tip."""
    uv = 0.01 * np.asarray(mesh.uv_cm, dtype=float)
    vp = np.asarray(mesh.vertex_panel)
    out = []
    for k, st in enumerate(mesh.stitches):
        if st.panel_a != st.panel_b:
            continue
        pr = np.asarray(mesh.stitch_pairs[k])
        if len(pr) < 2:
            continue
        if pr[-1, 0] == pr[-1, 1]:
            pr = pr[::-1]
        if pr[0, 0] != pr[0, 1] or np.any(pr[1:, 0] == pr[1:, 1]):
            continue
        tip, a, b = int(pr[0, 0]), pr[1:, 0], pr[1:, 1]
        z_open = 0.5 * (xbar[a[-1], 2] + xbar[b[-1], 2])
        reach = 0.5 * (xbar[a[-1]] + xbar[b[-1]]) - xbar[tip]
        if abs(reach[2]) < np.linalg.norm(reach[:2]):
            continue
        mid = 0.5 * (uv[a[-1]] + uv[b[-1]])
        axis = mid - uv[tip]
        if np.linalg.norm(axis) <= 0:
            continue
        along = axis / np.linalg.norm(axis)
        across = np.array([-along[1], along[0]])
        out.append({"tip": tip, "legs": (a, b), "along": along, "across": across, "mid": mid,
                    "intake": abs(float((uv[a[-1]] - uv[b[-1]]) @ across)),
                    "z_open": float(z_open), "z_tip": float(xbar[tip, 2]), "panel": int(vp[tip])})
    return out


def _dart_wedges(mesh, xbar, profile, S):
    """Triangles filling each vertical dart's wedge in the pattern, (k, 3) vertex ids, and
    their target gradients (k, 2, 2). A dart takes up what the girth at its tip grew beyond
    the girth at its open end, as drafts do: the panel's row at the open end grows as the
    row at the tip did (its side seams keep their shape) while its cloth there grows by the
    open end's own stretch, so across the dart the wedge stretches by
    s_d = sx_tip + (sx_tip - sx_open) C / I, C the row's cloth and I its darts' intake."""
    none = np.zeros((0, 3), np.int64), np.zeros((0, 2, 2))
    darts = _darts(mesh, xbar)
    if not darts:
        return none
    uv = 0.01 * np.asarray(mesh.uv_cm, dtype=float)
    vp = np.asarray(mesh.vertex_panel)
    tri_all = np.asarray(mesh.triangles)
    tris, targets = [], []
    for d in darts:
        # The panel's row through the open end: its width across the dart, less the
        # intake of every dart that opens on it, is the cloth there.
        pv = np.flatnonzero(vp == d["panel"])
        row = pv[np.abs((uv[pv] - d["mid"]) @ d["along"]) < DART_ROW_M]
        on_row = [e["intake"] for e in darts if e["panel"] == d["panel"]
                  and abs((e["mid"] - d["mid"]) @ d["along"]) < DART_ROW_M]
        intake = sum(on_row)
        cloth = (float(np.ptp(uv[row] @ d["across"])) if len(row) >= 2 else 0.0) - intake
        if cloth <= 0 or intake <= 0:
            continue
        sx_open, sx_tip = np.interp([d["z_open"], d["z_tip"]], profile["z"], profile["sx"])
        s_d = float(np.clip(sx_tip + (sx_tip - sx_open) * cloth / intake, *DART_STRETCH))
        # Along the dart it stretches as the cloth beside it.
        a, b = d["legs"]
        beside = np.isin(tri_all, np.concatenate([a, b])).any(axis=1)
        e = d["along"]
        sy = float(np.mean(np.einsum("i,tij,j->t", e, S[beside], e))) if beside.any() else 1.0
        target = np.eye(2) + (s_d - 1.0) * np.outer(d["across"], d["across"]) + (sy - 1.0) * np.outer(e, e)
        chain = list(zip(a.tolist(), b.tolist()))
        wedge = [(d["tip"], *chain[0])]
        for (a0, b0), (a1, b1) in zip(chain[:-1], chain[1:]):
            wedge += [(a0, a1, b1), (a0, b1, b0)]
        tris += wedge
        targets += [target] * len(wedge)
    if not tris:
        return none
    return np.asarray(tris, np.int64), np.asarray(targets)


def level_scaled_pattern(mesh, xbar, base_body, target_body, base_sdf, *, return_info: bool = False):
    """p-hat (N, 2) m: the base pattern stretched level by level (module docstring)."""
    xbar = np.asarray(xbar, dtype=float)
    levels = base_levels(base_body)             # measured once: the slowest part of the start
    one_tube = passes_crotch_as_one_tube(mesh, xbar, base_body, levels)
    zmap = level_map(base_body, target_body, levels=levels, crotch=not one_tube)
    sleeves = sleeve_targets(mesh, xbar, base_body, target_body, levels)
    prof = girth_profile(mesh, xbar, base_body, target_body, base_sdf, levels, skip=sleeves[0])
    if one_tube and prof["hip_supported"]:
        # A skirt or dress the seat holds is drafted down from the waist by the body's
        # waist-to-hip: its seat line moves with that length, not with the stature.
        zmap = with_seat_line(zmap, base_body, target_body)
    zmap = with_shoulder_line(zmap, base_body, target_body)
    flare = one_tube and not prof["hip_supported"]
    if flare:
        # A skirt the hip does not hold (a circle skirt) hangs from the natural waist.
        zmap = with_natural_waist(zmap, base_body, target_body)
    darted = darted_above_the_waist(mesh, xbar, levels)
    if darted:
        zmap = with_bust_point(zmap, base_body, target_body)
    # A darted bodice's front grows between its bust points as the bust span did.
    S, E2, across, on_arm = _stretch_targets(mesh, xbar, prof, zmap, sleeves,
                                             bust_span(base_body, target_body, levels) if darted else None)
    # Each dart's wedge joins the fit as triangles of its own, so its intake follows the
    # girths at its tip and its open end (_dart_wedges).
    wt, wS = _dart_wedges(mesh, xbar, prof, S)
    P = 0.01 * np.asarray(mesh.uv_cm, dtype=float)[wt]
    wE2 = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)
    ok = np.abs(np.linalg.det(wE2)) > 1e-12 if len(wt) else np.zeros(0, dtype=bool)
    fit = _gradient_solver(mesh, np.concatenate([E2, wE2[ok]]),
                           np.concatenate([np.asarray(mesh.triangles), wt[ok]]))

    def solve(S_):
        return fit(np.concatenate([S_, wS[ok]]))

    # Each supported level's growth held against the fit's compromise (_held_girths).
    p = solve(_held_girths(mesh, xbar, S, E2, across, on_arm, prof, solve))
    if return_info:
        tri_panel = np.asarray(mesh.vertex_panel)[np.asarray(mesh.triangles)[:, 0]]
        sleeve_panels = [mesh.panel_names[k] for k in np.unique(tri_panel[sleeves[0]])]
        return p, {"levels": zmap, "profile": prof, "sleeve_panels": sleeve_panels,
                   "seat_line": bool(one_tube and prof["hip_supported"]), "natural_waist": bool(flare)}
    return p
