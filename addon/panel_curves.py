# SPDX-License-Identifier: GPL-3.0-or-later
"""Panels as Bezier curves an artist can edit, and the edits read back into edges.

Each edge of a panel is drawn as one Bezier segment (an arc as one per quarter turn): its
start is a curve point, its control points are the handles (a line has vector handles, a
quadratic the handles of the same curve as a cubic). The object remembers which edge each
segment belongs to and where every point and handle was drawn, so reading back tells which
edges were edited; the others keep their curves and outline points exactly. A panel whose
edges do not run around its outline is drawn as its outline points, joined by lines.
"""
from __future__ import annotations

import math

import numpy as np

from . import compute

SEGMENTS_KEY = "seamfit_segments"   # object: per curve point, the id of the edge its segment draws (-1: outline)
DRAWN_KEY = "seamfit_drawn"         # object: points, left and right handles as drawn (local m), to tell edits
# A point or handle nearer than this (cm) to where it was drawn has not been moved: Blender
# keeps curves in float32 metres (~1e-5 cm), and the pattern keeps its own float64 values there.
UNEDITED_CM = 1e-3
# An edited arc stays an arc if the drawn curve is this close (cm) to one: refit's tolerance.
ARC_TOL_CM = 0.05
_QUARTER = 0.5 * math.pi
_ARC_SAMPLES = 16                   # per segment, to fit an edited arc


def edge_segments(edge) -> list[np.ndarray]:
    """The cubic Bezier segments (k, 4, 2) in cm that draw an edge."""
    p0, p1 = np.asarray(edge.p0, float), np.asarray(edge.p1, float)
    if edge.kind == "line":
        return [np.array([p0, p0 + (p1 - p0) / 3.0, p1 - (p1 - p0) / 3.0, p1])]
    if edge.kind == "quadratic":
        q = np.asarray(edge.ctrl[0], float)
        return [np.array([p0, p0 + 2.0 / 3.0 * (q - p0), p1 + 2.0 / 3.0 * (q - p1), p1])]
    if edge.kind == "cubic":
        return [np.array([p0, *np.asarray(edge.ctrl, float), p1])]
    a = edge.arc
    c, r, a0, a1 = np.asarray(a["center"], float), float(a["radius"]), float(a["angle0_rad"]), float(a["angle1_rad"])
    k = max(1, math.ceil(abs(a1 - a0) / _QUARTER - 1e-9))
    angles = np.linspace(a0, a1, k + 1)
    h = 4.0 / 3.0 * math.tan((a1 - a0) / k / 4.0) * r      # handle length of a circular cubic
    segs = []
    for t0, t1 in zip(angles[:-1], angles[1:]):
        u0, u1 = np.array([math.cos(t0), math.sin(t0)]), np.array([math.cos(t1), math.sin(t1)])
        d0, d1 = np.array([-u0[1], u0[0]]), np.array([-u1[1], u1[0]])
        segs.append(np.array([c + r * u0, c + r * u0 + h * d0, c + r * u1 - h * d1, c + r * u1]))
    segs[0][0], segs[-1][3] = p0, p1
    return segs


def _drawing(panel):
    """(segments (K, 4, 2) cm, edge id per segment, whether each is a line) for a panel."""
    order = compute.edges_in_order(panel)
    if order is None:
        o = np.asarray(panel.outline_cm, float)
        nxt = np.roll(o, -1, axis=0)
        segs = np.stack([o, o + (nxt - o) / 3.0, nxt - (nxt - o) / 3.0, nxt], axis=1)
        return segs, [-1] * len(o), [True] * len(o)
    segs, owner, line = [], [], []
    for e in order:
        s = edge_segments(e)
        segs += s
        owner += [e.id] * len(s)
        line += [e.kind == "line"] * len(s)
    return np.asarray(segs), owner, line


def build_spline(cu, panel) -> list[int]:
    """Add the panel's closed Bezier spline to curve data ``cu``; returns the edge id each
    segment draws (for remember)."""
    segs, owner, line = _drawing(panel)
    k = len(segs)
    sp = cu.splines.new("BEZIER")
    sp.bezier_points.add(k - 1)
    sp.use_cyclic_u = True
    bp = sp.bezier_points
    # Vector handles keep a line straight when its points move; the others are free, so a
    # handle moves only the edge it belongs to.
    for j in range(k):
        bp[j].handle_right_type = "VECTOR" if line[j] else "FREE"
        bp[j].handle_left_type = "VECTOR" if line[j - 1] else "FREE"
    for attr, col in (("co", 0), ("handle_right", 1), ("handle_left", None)):
        pts = segs[:, col] if col is not None else np.roll(segs[:, 2], 1, axis=0)
        xyz = np.zeros((k, 3))
        xyz[:, :2] = 0.01 * pts
        bp.foreach_set(attr, xyz.ravel())
    return owner


def remember(obj, owner: list[int]) -> None:
    """Store on the panel's object which edge each segment draws and where the points and
    handles are now, as what was drawn."""
    obj[SEGMENTS_KEY] = [int(i) for i in owner]
    obj[DRAWN_KEY] = _read(obj.data.splines[0], scale=(1.0, 1.0)).ravel().tolist()


def _read(sp, scale) -> np.ndarray:
    """(3, K, 2): points, left handles, right handles in cm (local frame, object scale applied)."""
    bp = sp.bezier_points
    out = np.empty((3, len(bp), 2))
    for n, attr in enumerate(("co", "handle_left", "handle_right")):
        v = np.empty(3 * len(bp))
        bp.foreach_get(attr, v)
        out[n] = 100.0 * v.reshape(-1, 3)[:, :2] * np.asarray(scale[:2], float)
    return out


def read_panel(obj, panel, scale) -> tuple[np.ndarray | None, dict]:
    """What the artist changed on a panel's curve: (new outline or None, for outline-drawn
    panels; {edge id: dict(kind, p0, p1, ctrl, arc)} of the edited edges, and under
    compute.POINTS_KEY the edges split at added points and joined at deleted ones, in order)."""
    where = f"panel {panel.name!r}"
    owner = list(obj.get(SEGMENTS_KEY, []))
    if obj.type != "CURVE" or len(obj.data.splines) != 1 or obj.data.splines[0].type != "BEZIER":
        raise compute.AddonError(f"{where}: its object must stay one curve with one Bezier spline")
    sp = obj.data.splines[0]
    k = len(sp.bezier_points)
    if DRAWN_KEY not in obj or (k != len(owner) and (not owner or owner[0] == -1)):
        raise compute.AddonError(
            f"{where}: the curve has {k} points but the pattern's outline was drawn with {len(owner)}; "
            f"move points instead of adding or deleting them")
    cur = _read(sp, scale)
    drawn = np.asarray(obj[DRAWN_KEY], float).reshape(3, len(owner), 2)
    if k != len(owner):
        return None, _read_points(sp, panel, cur, drawn, owner, where)
    moved = np.linalg.norm(cur - drawn, axis=2) > UNEDITED_CM        # (3, K)
    if not moved.any():
        return None, {}
    if owner[0] == -1:
        o = np.asarray(panel.outline_cm, float)
        return np.where(moved[0][:, None], cur[0], o), {}
    segs, _, _ = _drawing(panel)
    # Exact values where nothing moved, the artist's where it did.
    co = np.where(moved[0][:, None], cur[0], segs[:, 0])
    left = np.where(moved[1][:, None], cur[1], np.roll(segs[:, 2], 1, axis=0))
    right = np.where(moved[2][:, None], cur[2], segs[:, 1])
    edges = {e.id: e for e in panel.edges}
    return None, _edited_edges(sp, edges, owner, co, left, right, moved, {}, where)


def _edited_edges(sp, edges: dict, owner: list[int], co, left, right, moved, refit: dict, where: str) -> dict:
    """{edge id: its new curve} for the edges whose segments moved, or that ``refit`` names
    (id: the kind to fit), from the points and handles in curve order; ``owner[0]`` starts an edge."""
    k = len(owner)
    vector = [(p.handle_right_type == "VECTOR", p.handle_left_type == "VECTOR") for p in sp.bezier_points]
    changes, j = {}, 0
    while j < k:
        eid, j0 = owner[j], j
        while j < k and owner[j] == eid:
            j += 1
        seg = list(range(j0, j))
        end = j % k
        # A segment is its start point, its right handle and the next point's left handle.
        if eid not in refit and not (moved[0, seg].any() or moved[2, seg].any() or moved[1, seg[1:]].any()
                                     or moved[0, end] or moved[1, end]):
            continue
        p0, p1 = co[j0], co[end]
        cubic = [np.array([co[i], right[i], left[(i + 1) % k], co[(i + 1) % k]]) for i in seg]
        kind = refit.get(eid, edges[eid].kind if eid in edges else None)
        changes[eid] = _edge_from(edges.get(eid), cubic, p0, p1, vector[j0][0] and vector[end][1], moved, seg,
                                  end, f"{where} edge {eid} ({kind})", refit.get(eid))
    return changes


def _read_points(sp, panel, cur, drawn, owner: list[int], where: str) -> dict:
    """The edits of a curve whose points were added or deleted: the points that were there
    keep their identity (where they were drawn, else in order), an added point splits the
    edge it falls on, a deleted edge start joins its two edges; the edges so made take the
    curve the points and handles now draw."""
    k, kd = cur.shape[1], drawn.shape[1]
    match = _match_points(cur[0], drawn[0], where)              # current point -> drawn point or -1
    kept = set(match[match >= 0].tolist())
    starts = [j for j in range(kd) if owner[j] != owner[j - 1]]
    ops, joined_into, refit = [], {}, {}

    def resolve(eid):
        while eid in joined_into:
            eid = joined_into[eid]
        return eid

    # A deleted edge start joins its edge onto the one before (which keeps its id).
    for j in range(kd):
        if j in kept:
            continue
        label = f"curve point {j} (at {drawn[0, j, 0]:.2f}, {drawn[0, j, 1]:.2f} cm)"
        if j in starts:
            a = resolve(owner[j - 1])
            ops.append({"op": "join", "edges": [a, owner[j]], "point": label})
            joined_into[owner[j]] = a
            refit[a] = "cubic"
        else:
            refit.setdefault(resolve(owner[j]), None)
    if not any(j in kept for j in starts):
        raise compute.AddonError(f"{where}: every point where an edge starts was deleted; keep at least one")
    # Walk the curve from a kept edge start: each point's edge, with added points splitting it.
    first = next(i for i in range(k) if match[i] in starts)
    next_id = max(e.id for e in panel.edges) + 1
    new_owner, cur_edge = [0] * k, None
    for step in range(k):
        i = (first + step) % k
        j = int(match[i])
        if j in starts:
            cur_edge = owner[j]
        elif j < 0:
            ops.append({"op": "split", "edge": cur_edge, "at": [float(v) for v in cur[0, i]], "new_id": next_id,
                        "point": f"added curve point {i} (at {cur[0, i, 0]:.2f}, {cur[0, i, 1]:.2f} cm)"})
            refit.setdefault(cur_edge, None)
            refit[next_id] = None
            cur_edge = next_id
            next_id += 1
        new_owner[i] = cur_edge
    edges = {e.id: e for e in panel.edges}
    kinds = {}
    for op in ops:
        if op["op"] == "split":
            kinds[op["new_id"]] = kinds.get(op["edge"], edges[op["edge"]].kind)
        else:
            kinds[op["edges"][0]] = "cubic"
    # An edge drawn with several segments is fitted as one arc or one curve through them.
    n_seg = {eid: new_owner.count(eid) for eid in set(new_owner)}
    refit = {eid: ("arc" if n_seg[eid] > 1 else kinds.get(eid, edges[eid].kind if eid in edges else "cubic"))
             for eid in refit if eid in n_seg}
    # Exact values where a kept point and its handles did not move, the artist's elsewhere.
    segs, _, _ = _drawing(panel)
    exact = np.stack([segs[:, 0], np.roll(segs[:, 2], 1, axis=0), segs[:, 1]])      # (3, K drawn, 2)
    ref = np.where((match >= 0)[None, :, None], exact[:, np.maximum(match, 0)], np.nan)
    was = np.where((match >= 0)[None, :, None], drawn[:, np.maximum(match, 0)], np.nan)
    with np.errstate(invalid="ignore"):
        moved = ~(np.linalg.norm(cur - was, axis=2) <= UNEDITED_CM)
    co, left, right = (np.where(moved[n][:, None], cur[n], ref[n]) for n in range(3))
    # From a kept edge start, so that no edge's segments wrap past the last point.
    order = [(first + i) % k for i in range(k)]
    changes = _edited_edges(_Reordered(sp, order), edges, [new_owner[i] for i in order], co[order], left[order],
                            right[order], moved[:, order], refit, where)
    changes[compute.POINTS_KEY] = ops
    return changes


class _Reordered:
    """A spline's points in another order (for the handle types _edited_edges reads)."""
    def __init__(self, sp, order):
        self.bezier_points = [sp.bezier_points[i] for i in order]


def _match_points(cur: np.ndarray, drawn: np.ndarray, where: str) -> np.ndarray:
    """For each current point the drawn point it is (-1: added). Points where they were drawn
    anchor the match; between two anchors the rest pair up in order, nearest first when
    points were added or deleted there."""
    k, kd = len(cur), len(drawn)
    d = np.linalg.norm(cur[:, None] - drawn[None], axis=2)
    match = np.full(k, -1)
    j0, last = None, -1
    for i in range(k):
        j = int(np.argmin(d[i]))
        if d[i, j] <= UNEDITED_CM:
            j0 = j if j0 is None else j0
            if (j - j0) % kd > last:                # in drawn order: a stacked point is not taken twice
                last = (j - j0) % kd
                match[i] = j
    anchors = [i for i in range(k) if match[i] >= 0]
    if not anchors:
        raise compute.AddonError(f"{where}: points were added or deleted and none of the others is where it "
                                 f"was drawn; apply the moves first, then add or delete points")
    for a, b in zip(anchors, anchors[1:] + anchors[:1]):
        ci = [(a + s) % k for s in range(1, (b - a - 1) % k + 1)]
        dj = [(match[a] + s) % kd for s in range(1, (match[b] - match[a] - 1) % kd + 1)]
        for i, j in _pair_in_order(ci, dj, d):
            match[i] = j
    return match


def _pair_in_order(ci: list[int], dj: list[int], d: np.ndarray) -> list[tuple[int, int]]:
    """As many (current, drawn) pairs as the shorter list has, in order, nearest in sum."""
    if not ci or not dj:
        return []
    if len(ci) == len(dj):
        return list(zip(ci, dj))
    swap = len(ci) > len(dj)
    short, long_ = (dj, ci) if swap else (ci, dj)
    cost = (lambda s, l: d[l, s]) if swap else (lambda s, l: d[s, l])     # noqa: E731
    ns, nl = len(short), len(long_)
    # f[a][b]: least cost pairing the first a of short with some of the first b of long.
    f = np.full((ns + 1, nl + 1), np.inf)
    f[0, :] = 0.0
    for a in range(1, ns + 1):
        for b in range(a, nl + 1):
            f[a, b] = min(f[a, b - 1], f[a - 1, b - 1] + cost(short[a - 1], long_[b - 1]))
    pairs, a, b = [], ns, nl
    while a > 0:
        if f[a, b] == f[a, b - 1] and b > a:
            b -= 1
        else:
            pairs.append((short[a - 1], long_[b - 1]))
            a, b = a - 1, b - 1
    pairs.reverse()
    return [(l, s) for s, l in pairs] if swap else pairs


def _edge_from(e, cubic, p0, p1, straight: bool, moved, seg, end, where: str, refit: str | None = None) -> dict:
    """The edited edge: a line while its handles are vector handles (or lie on it), the
    quadratic or cubic its handles make, and an arc while the drawn curve is one. ``refit``
    (a kind) fits an edge that points were added to or deleted from as that kind."""
    base = {"p0": [float(v) for v in p0], "p1": [float(v) for v in p1]}
    kind = refit or e.kind
    if kind == "arc":
        # Moving an end point in Blender moves its handles along: the arc follows its ends.
        inner = refit or (moved[:, seg[1:]].any() or (moved[2, seg[0]] and not moved[0, seg[0]])
                          or (moved[1, end] and not moved[0, end]))
        if not inner:
            return {**base, "kind": "arc", "arc": _moved_arc(e, p0, p1)}
        t = np.linspace(0.0, 1.0, _ARC_SAMPLES + 1)[:-1]
        samples = np.concatenate([_bezier(c, t) for c in cubic])[1:]
        arc, dev = compute.arc_through(p0, p1, samples)
        if dev <= ARC_TOL_CM:
            return {**base, "kind": "arc", "arc": arc}
        # The segments' own parameters, run end to end, start the fit.
        params = (np.concatenate([i + t for i in range(len(cubic))]) / len(cubic))[1:]
        ctrl, dev = compute.cubic_through(p0, p1, samples, params)
        if dev > ARC_TOL_CM:
            raise compute.AddonError(f"{where}: its {len(cubic)} segments no longer make one arc or one curve "
                                     f"({dev:.2f} cm off); move its end points or fewer of its handles")
        return {**base, "kind": "cubic", "ctrl": ctrl}
    if len(cubic) == 1 and (straight or (kind == "line" and _on_chord(cubic[0]))):
        return {**base, "kind": "line"}
    h1, h2 = cubic[0][1], cubic[0][2]
    q1, q2 = (3.0 * h1 - p0) / 2.0, (3.0 * h2 - p1) / 2.0
    if kind in ("line", "quadratic") and np.linalg.norm(q1 - q2) <= UNEDITED_CM:
        return {**base, "kind": "quadratic", "ctrl": [[float(v) for v in 0.5 * (q1 + q2)]]}
    return {**base, "kind": "cubic", "ctrl": [[float(v) for v in h1], [float(v) for v in h2]]}


def _on_chord(cp: np.ndarray) -> bool:
    """The segment's handles lie on the line between its points, within the edit tolerance."""
    chord = cp[3] - cp[0]
    span = float(np.linalg.norm(chord))
    if span <= UNEDITED_CM:
        return False
    s = (cp[1:3] - cp[0]) @ chord / span
    d = cp[1:3] - cp[0]
    # the 2D cross product, written out: numpy 2 deprecates np.cross of 2D vectors and numpy
    # 2.5 refuses it (Blender 5.1 and later run numpy 2)
    off = np.abs(chord[0] * d[:, 1] - chord[1] * d[:, 0]) / span
    return bool((off <= UNEDITED_CM).all() and (s >= 0).all() and (s <= span).all())


def _moved_arc(e, p0, p1) -> dict:
    """The arc carried along with its moved end points (turned and scaled about them)."""
    a = e.arc
    old0, old1 = complex(*e.p0), complex(*e.p1)
    z = (complex(*p1) - complex(*p0)) / (old1 - old0)
    c = complex(*p0) + z * (complex(*a["center"]) - old0)
    turn = math.atan2(z.imag, z.real)
    return {"center": [c.real, c.imag], "radius": float(a["radius"]) * abs(z),
            "angle0_rad": float(a["angle0_rad"]) + turn, "angle1_rad": float(a["angle1_rad"]) + turn}


def _bezier(cp: np.ndarray, t: np.ndarray) -> np.ndarray:
    t = t[:, None]
    return ((1 - t) ** 3 * cp[0] + 3 * (1 - t) ** 2 * t * cp[1] + 3 * (1 - t) * t ** 2 * cp[2] + t ** 3 * cp[3])
