"""Sleeves graded around the arm (docs/method.md, "Sleeves around the arm").

Level scaling measures girths at heights, which is right for a torso or a trouser leg: they
stand upright. An arm in the bodies' rest pose (A-pose) hangs about 45 degrees out, so a
horizontal level cuts a sleeve obliquely and a level above the armpit runs round both
shoulders and both sleeves at once. A sleeve is drafted from the arm's girths (the upper arm
at the bicep) and its length along the arm, so here each sleeve gets its own levels: planes
across the arm's centre line, the same measurement as a level's (the growth of the body
section the sleeve encloses, the cloth's girth there).

A sleeve is a panel more of whose vertices lie nearest the arm below the armpit than nearest
the torso below it (read off the base garment draped on the base body; a sleeve's cap lies
above the armpit, by neither); cut-on sleeves stay with the torso's levels.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..body.measure import _hull_perimeter, _Slicer, encloses
from .fit import hull as _hull
from .fit import mesh_cross_section

ARM_STEP_M = 0.01
# An arm section is the arm's alone while its points stay within this many arm radii of
# the centre line; nearer the shoulder the plane also cuts the torso.
ARM_REACH = 2.5
# Centre-line samples above the armpit, continued straight up the arm (the cap).
CAP_SAMPLES = 12


def _planar_perimeter(q) -> float:
    """Hull perimeter of 3-D section points in their own best plane (the target's section,
    the same edge crossings, is not exactly planar; the base's is measured the same way so
    that equal bodies give equal girths)."""
    c = q.mean(axis=0)
    _, _, vt = np.linalg.svd(q - c, full_matrices=False)
    return _hull_perimeter((q - c) @ vt[:2].T)


def _frame(direction):
    """Rows: two unit vectors across ``direction`` and ``direction`` itself. (Like
    measure_landmarks._frame but for its helper axis; the sleeves' planes are measured in
    this frame, and a change of frame moves the graded t-shirts by up to 0.1 cm through the
    search's sensitivity to the last digits.)"""
    a = direction / np.linalg.norm(direction)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    return np.vstack([u, np.cross(a, u), a])


def _loop_centroid(segs) -> np.ndarray:
    mid = segs.mean(axis=1)
    w = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    return (mid * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300)


def arm_lines(base_body, levels: dict) -> list[dict]:
    """Per arm: centre-line points P (k, 3) from above the armpit down the arm, unit
    directions A (k, 3) down the arm, the arm's radius, and the body vertices of the arm
    below the armpit. Empty where the body has no separate arm sections."""
    s = _Slicer(base_body)
    armpit, crotch = float(levels["armpit"]), float(levels["crotch"])
    # Below the armpit each arm is a piece of the body mesh of its own.
    V, F = np.asarray(base_body.vertices), np.asarray(base_body.faces)
    low = (V[F, 2] < armpit - ARM_STEP_M).all(axis=1)
    e = np.vstack([F[low][:, [0, 1]], F[low][:, [1, 2]]])
    _, piece = connected_components(sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])),
                                                  shape=(len(V), len(V))), directed=False)
    out = []
    for side in (1.0, -1.0):
        pts, radii, verts, torso_v = [], [], [], []
        for z in np.arange(armpit - ARM_STEP_M, crotch, -ARM_STEP_M):
            torso = {id(t) for t in s.torso(z)[0]}
            a, b, t, _ = s.cut(z)
            loops = list(zip(s.loops(z), s.loop_ids(z)))
            torso_v += [np.concatenate([a[ids], b[ids]]) for segs, ids in loops if id(segs) in torso]
            cands = [(segs, ids) for segs, ids in loops
                     if id(segs) not in torso and side * (_loop_centroid(segs)[0] - s.axis[0]) > 0]
            if not cands:
                break
            segs, ids = max(cands, key=lambda c: np.linalg.norm(c[0][:, 1] - c[0][:, 0], axis=1).sum())
            c = _loop_centroid(segs)
            pts.append([c[0], c[1], z])
            radii.append(float(np.median(np.linalg.norm(segs.reshape(-1, 2) - c, axis=1))))
            verts.append(np.concatenate([a[ids], b[ids]]))
        if len(pts) < 5:
            continue
        P = np.asarray(pts)
        # directions from a few samples apart, so the section's wobble does not tilt them
        k = np.arange(len(P))
        A = P[np.minimum(k + 3, len(P) - 1)] - P[np.maximum(k - 3, 0)]
        A /= np.linalg.norm(A, axis=1, keepdims=True)
        up = -A[0]
        cap = P[0] + ARM_STEP_M * np.arange(CAP_SAMPLES, 0, -1)[:, None] * up
        P = np.vstack([cap, P])
        A = np.vstack([np.repeat(A[:1], CAP_SAMPLES, axis=0), A])
        # An arm that touches the body lower down (a hand on the hip) shares its piece
        # with the torso: then only its own sections' vertices are the arm's.
        torso_pieces = piece[np.concatenate(torso_v)] if torso_v else np.zeros(0, piece.dtype)
        pieces = np.setdiff1d(piece[np.concatenate(verts)], torso_pieces)
        arm_v = np.flatnonzero(np.isin(piece, pieces) & (V[:, 2] < armpit - ARM_STEP_M))
        if len(arm_v) == 0:
            arm_v = np.unique(np.concatenate(verts))
        out.append({"P": P, "A": A, "radius": float(np.median(radii)), "vertices": arm_v,
                    "armpit": armpit - ARM_STEP_M})
    return out


def sleeve_panels(mesh, xbar, base_body, arms) -> np.ndarray:
    """Per panel, the index into ``arms`` of the arm it sleeves, or -1."""
    vp = np.asarray(mesh.vertex_panel)
    out = np.full(len(mesh.panel_names), -1)
    if not arms:
        return out
    V = np.asarray(base_body.vertices)
    label = np.full(len(V), -1)
    label[V[:, 2] < arms[0]["armpit"]] = len(arms)          # the torso (and legs) below it
    for i, arm in enumerate(arms):
        label[arm["vertices"]] = i
    from scipy.spatial import cKDTree   # here, not at the top: as in seamfit.opt.fit
    _, nearest = cKDTree(V).query(xbar)
    lab = label[nearest]
    for p in range(len(out)):
        mine = lab[vp == p]
        counts = np.bincount(mine[mine >= 0], minlength=len(arms) + 1)
        i = int(np.argmax(counts))
        if i < len(arms) and counts[i] > 0:
            out[p] = i
    return out


def _arm_profile(arm, base_body, target_body, x_rot_tri) -> dict:
    """Per centre-line sample: G (the sleeve's girth across the arm), H (the girth of the
    arm section it encloses), dH (that section's growth on the target) and sx = 1 + dH / G,
    taken from the nearest sample that has them where the plane is not the arm's alone
    (module docstring). ``x_rot_tri(origin, R)`` gives the garment's vertices in the
    plane's frame and the sleeve's triangles."""
    from scipy.spatial import Delaunay
    V = np.asarray(base_body.vertices, dtype=float)
    F = np.asarray(base_body.faces)
    tv = np.asarray(target_body.vertices, dtype=float)
    P, A, r = arm["P"], arm["A"], arm["radius"]
    n = len(P)
    G, H, dH = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    for k in range(n):
        R = _frame(A[k])
        s = _Slicer(SimpleNamespace(vertices=(V - P[k]) @ R.T, faces=F))
        loops, loop_ids = s.loops(0.0), s.loop_ids(0.0)
        a, b, t, pts = s.cut(0.0)
        # the loop round the centre line
        mine = None
        for segs, ids in zip(loops, loop_ids):
            if encloses(segs, 0.0, 0.0):
                mine = ids
        if mine is None or np.linalg.norm(pts[mine], axis=1).max() > ARM_REACH * r:
            continue
        x_rot, tri = x_rot_tri(P[k], R)
        cloth = mesh_cross_section(x_rot, tri, 0.0)
        cloth = cloth[np.linalg.norm(cloth, axis=1) < 2 * ARM_REACH * r]
        if len(cloth) < 3:
            continue
        h = _hull(cloth)
        if h is None:
            continue
        g = _hull_perimeter(cloth)
        inside = mine[Delaunay(cloth[h.vertices]).find_simplex(pts[mine]) >= 0]
        if len(inside) < 3:
            continue
        h0 = _planar_perimeter(V[a[inside]] + t[inside, None] * (V[b[inside]] - V[a[inside]]))
        h1 = _planar_perimeter(tv[a[inside]] + t[inside, None] * (tv[b[inside]] - tv[a[inside]]))
        if np.isfinite(h0) and np.isfinite(h1):
            G[k], H[k], dH[k] = g, h0, h1 - h0
    ok = np.flatnonzero(np.isfinite(dH))
    sx = np.ones(n)
    if len(ok) == 0:
        return {"sx": sx, "G": G, "H": H, "dH": dH}
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    sx = np.interp(arc, arc[ok], 1.0 + dH[ok] / G[ok])
    return {"sx": sx, "G": G, "H": H, "dH": dH}


def sleeve_targets(mesh, xbar, base_body, target_body, levels: dict):
    """(sleeve triangle mask, per-triangle sx and the arm's direction up to the shoulder)
    for every sleeve panel; the mask is all False where the garment has none. Along the arm
    a sleeve keeps the level map's stretch: its length follows the body's heights, as the
    torso's does."""
    tri = np.asarray(mesh.triangles)
    T = len(tri)
    mask = np.zeros(T, dtype=bool)
    sx, up = np.ones(T), np.tile([0.0, 0.0, 1.0], (T, 1))
    arms = arm_lines(base_body, levels)
    panel_arm = sleeve_panels(mesh, xbar, base_body, arms)
    if (panel_arm < 0).all():
        return mask, sx, up
    tri_panel = np.asarray(mesh.vertex_panel)[tri[:, 0]]
    cent = xbar[tri].mean(axis=1)
    for i, arm in enumerate(arms):
        mine = np.isin(tri_panel, np.flatnonzero(panel_arm == i))
        if not mine.any():
            continue
        tri_i = tri[mine]

        def x_rot_tri(origin, R, tri_i=tri_i):
            return (xbar - origin) @ R.T, tri_i

        prof = _arm_profile(arm, base_body, target_body, x_rot_tri)
        if not np.isfinite(prof["dH"]).any():
            continue            # no plane measured the sleeve: it keeps the torso's levels
        from scipy.spatial import cKDTree
        _, k = cKDTree(arm["P"]).query(cent[mine])
        mask[mine] = True
        sx[mine], up[mine] = prof["sx"][k], -arm["A"][k]
    return mask, sx, up
