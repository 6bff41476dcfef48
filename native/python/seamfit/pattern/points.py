"""Add and delete points of a panel's edge loop, as an artist adds or deletes curve points:
split an edge in two at a point of its curve, or join two neighbouring edges into one curve
fitted through both. Stitches keep sewing the same stretch of boundary (stitch ranges are
outline index ranges, so a side that now spans both halves of a split edge stays one range),
every other outline index follows its edge, and the input pattern is not modified.
"""
from __future__ import annotations

import copy

import numpy as np

from ..errors import PatternError
from . import curves
from .edit import _LENGTH_DIGITS, arc_through, cubic_through, edges_in_order, edit_edges, reindex
from .model import Edge, Pattern
from .refit import side_length_cm
from .validate import CURVE_OUTLINE_TOL_CM, validate_pattern

# A split this close (cm) to an outline sample splits there: the outline keeps its points
# and gains no segment shorter than the curve/outline tolerance validation allows.
SNAP_CM = CURVE_OUTLINE_TOL_CM
# A joined edge stays a line or an arc when both halves are this close (cm) to one: refit's tolerance.
JOIN_TOL_CM = 0.05
_N_DENSE = 2048                 # polyline segments to find a point's parameter on a curve
_N_JOIN = 32                    # samples per edge to fit the joined curve


def split_edge(pattern: Pattern, panel_name: str, edge_id: int, at, *, new_id: int | None = None,
               point: str | None = None, check: bool = True) -> tuple[Pattern, int]:
    """A copy of ``pattern`` in which edge ``edge_id`` of panel ``panel_name`` is split at the
    point of its curve nearest ``at`` (u, v in cm): the edge keeps its id up to there, and a
    new edge (``new_id``, by default one more than the panel's largest id) runs on to the old
    end. The curve is unchanged; the outline keeps its points and gains the split point.
    Returns (pattern, id of the new edge). ``point`` names the point in messages; with
    ``check`` the result is validated (a PatternError for any error the input did not have)."""
    out = copy.deepcopy(pattern)
    panel, where = _panel(out, panel_name)
    order = edges_in_order(panel, where)
    e = _edge(order, edge_id, where)
    ids = {x.id for x in order}
    new_id = max(ids) + 1 if new_id is None else int(new_id)
    if new_id in ids:
        raise PatternError(f"{where}: edge id {new_id} is taken")
    label = point or f"the point at ({float(at[0]):.2f}, {float(at[1]):.2f}) cm"
    n = panel.n_vertices
    o = np.asarray(panel.outline_cm, dtype=float)
    idx = (e.start + np.arange((e.end - e.start) % n + 1)) % n
    ts = _parameters(e, o[idx])
    ts[0], ts[-1] = 0.0, 1.0
    t = float(_parameters(e, np.asarray(at, float).reshape(1, 2))[0])
    q = curves.evaluate(e, [t])[0]
    k = int(np.clip(np.searchsorted(ts, t), 1, len(ts) - 1))      # ts[k-1] <= t <= ts[k]
    near = min((k - 1, k), key=lambda j: float(np.linalg.norm(o[idx[j]] - q)))
    if np.linalg.norm(o[idx[near]] - q) <= SNAP_CM:
        if near in (0, len(idx) - 1):
            raise PatternError(f"{where}: {label} is on an end of edge {e.id}, where a point already is")
        t, q = float(ts[near]), o[idx[near]]
        v, ins = int(idx[near]), None
    else:
        ins = int(idx[k - 1]) + 1                                   # the new outline vertex
        v = ins
    first, second = _split_curve(e, t)

    def m(i: int) -> int:
        return i + 1 if ins is not None and i >= ins else i

    end = m(e.end)
    if ins is not None:
        panel.outline_cm = np.insert(o, ins, q, axis=0)
        for x in panel.edges:
            x.start, x.end = m(x.start), m(x.end)
        reindex(out, panel, m)
    e.kind, e.p0, e.p1, e.ctrl, e.arc = first.kind, first.p0, first.p1, first.ctrl, first.arc
    e.end = v
    new = Edge(id=new_id, start=v, end=end, kind=second.kind, p0=second.p0, p1=second.p1, ctrl=second.ctrl,
               arc=second.arc, label=e.label, extra=copy.deepcopy(e.extra))
    measured = e.length_cm is not None
    for x in (e, new):
        if measured:
            x.length_cm = round(curves.length(x), _LENGTH_DIGITS)
    panel.edges.insert(panel.edges.index(e) + 1, new)
    if v not in panel.nodes:
        panel.nodes.append(v)
    n = panel.n_vertices
    for s in out.stitches:
        for side in (s.a, s.b):
            if side.panel == panel.name and side.edge == e.id and not _within(side.range, e.start, e.end, n):
                # A side over both halves names no single edge; one on the second half names it.
                side.edge = new_id if _within(side.range, new.start, new.end, n) else None
    _measure_stitches(out, panel.name)
    if check:
        _check(pattern, out, where, f"splitting edge {e.id} at {label}")
    return out, new_id


def join_edges(pattern: Pattern, panel_name: str, first_id: int, second_id: int, *,
               point: str | None = None, check: bool = True) -> Pattern:
    """A copy of ``pattern`` in which edge ``second_id`` of panel ``panel_name``, which starts
    where edge ``first_id`` ends, is joined onto it: one edge (``first_id``) with a curve
    fitted through both (a line or an arc when both halves are one, else a cubic), its
    outline sampled again. Refused (a one-line PatternError naming the panel and the point)
    when the point between them is a stitch end, a corner or a landmark."""
    out = copy.deepcopy(pattern)
    panel, where = _panel(out, panel_name)
    order = edges_in_order(panel, where)
    a, b = _edge(order, first_id, where), _edge(order, second_id, where)
    v = b.start
    label = point or f"the point between edges {a.id} and {b.id} (outline vertex {v})"
    if a.end != v:
        raise PatternError(f"{where}: edge {b.id} does not start where edge {a.id} ends")
    if len(order) < 3:
        raise PatternError(f"{where}: {label} cannot be deleted: a panel needs at least two edges")
    reasons = point_roles(out, panel.name, v)
    if reasons:
        raise PatternError(f"{where}: {label} cannot be deleted: it is {' and '.join(reasons)}")
    joined = _joined_curve(a, b)
    for s in out.stitches:
        for side in (s.a, s.b):
            if side.panel == panel.name and side.edge == b.id:
                side.edge = a.id
    a.end = b.end
    panel.edges.remove(b)
    panel.nodes = [i for i in panel.nodes if i != v]
    out = edit_edges(out, {panel.name: {a.id: joined}})
    if check:
        _check(pattern, out, where, f"deleting {label}")
    return out


def point_roles(pattern: Pattern, panel_name: str, vertex: int) -> list[str]:
    """What outline vertex ``vertex`` of a panel is to the pattern that keeps it from being
    deleted: stitch ends, a corner, landmarks (empty when none)."""
    panel = pattern.panel(panel_name)
    roles = [f"an end of stitch {k} ({s.kind}) side {tag}"
             for k, s in enumerate(pattern.stitches)
             for tag, side in (("a", s.a), ("b", s.b)) if side.panel == panel_name and vertex in side.range]
    if vertex in panel.corners:
        roles.append("a corner")
    roles += [f"landmark {name!r}" for name, i in panel.landmarks.items() if i == vertex]
    return roles


def _panel(pattern: Pattern, name: str):
    where = f"{pattern.source_file or '<pattern>'}: panel {name!r}"
    try:
        return pattern.panel(name), where
    except KeyError:
        raise PatternError(f"{pattern.source_file or '<pattern>'}: has no panel {name!r}") from None


def _edge(order: list[Edge], edge_id: int, where: str) -> Edge:
    for e in order:
        if e.id == edge_id:
            return e
    raise PatternError(f"{where}: has no edge {edge_id}")


def _parameters(edge: Edge, points: np.ndarray) -> np.ndarray:
    """The parameter of the curve point nearest each point (m, 2), from a dense polyline."""
    tq = np.linspace(0.0, 1.0, _N_DENSE + 1)
    dense = curves.evaluate(edge, tq)
    a, ab = dense[:-1], np.diff(dense, axis=0)
    ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    out = np.empty(len(points))
    for i, p in enumerate(np.asarray(points, float)):
        w = np.clip(np.einsum("ij,ij->i", p - a, ab) / ab2, 0.0, 1.0)
        j = int(np.argmin(np.linalg.norm(a + w[:, None] * ab - p, axis=1)))
        out[i] = tq[j] + w[j] * (tq[j + 1] - tq[j])
    return out


def _split_curve(e: Edge, t: float) -> tuple[Edge, Edge]:
    """The two halves of the edge's curve at parameter t, the same curve (de Casteljau)."""
    if e.kind == "arc":
        c, r, a0, a1 = curves.arc_params(e)
        am = a0 + t * (a1 - a0)
        mid = tuple(map(float, curves.evaluate(e, [t])[0]))
        arc = {"center": [float(c[0]), float(c[1])], "radius": r}
        return (Edge(-1, 0, 0, "arc", tuple(e.p0), mid, arc={**arc, "angle0_rad": a0, "angle1_rad": am}),
                Edge(-1, 0, 0, "arc", mid, tuple(e.p1), arc={**arc, "angle0_rad": am, "angle1_rad": a1}))
    cp = curves.control_points(e)
    left, right = [cp[0]], [cp[-1]]
    while len(cp) > 1:
        cp = (1.0 - t) * cp[:-1] + t * cp[1:]
        left.append(cp[0])
        right.append(cp[-1])
    right = right[::-1]
    pts = [[tuple(map(float, p)) for p in half] for half in (left, right)]
    return tuple(Edge(-1, 0, 0, e.kind, h[0], h[-1], ctrl=h[1:-1]) for h in pts)


def _joined_curve(a: Edge, b: Edge) -> Edge:
    """One curve from a's start to b's end through both: a line or an arc when both are one."""
    t = np.linspace(0.0, 1.0, _N_JOIN + 1)
    samples = np.concatenate([curves.evaluate(a, t[1:]), curves.evaluate(b, t[1:-1])])
    p0, p1 = np.asarray(a.p0, float), np.asarray(b.p1, float)
    base = dict(id=a.id, start=0, end=0, p0=tuple(map(float, p0)), p1=tuple(map(float, p1)))
    if a.kind == b.kind == "line":
        line = Edge(kind="line", **base)
        if curves.distance_to_curve(line, samples).max() <= JOIN_TOL_CM:
            return line
    if a.kind == b.kind == "arc":
        arc, dev = arc_through(p0, p1, samples)
        if dev <= JOIN_TOL_CM:
            return Edge(kind="arc", arc=arc, **base)
    ctrl, _ = cubic_through(p0, p1, samples)
    return Edge(kind="cubic", ctrl=ctrl, **base)


def _within(side_range, start: int, end: int, n: int) -> bool:
    """The forward range lies inside the outline range start..end (both wrapping)."""
    span = (end - start) % n
    i0, i1 = ((i - start) % n for i in side_range)
    return i0 <= i1 <= span


def _measure_stitches(pattern: Pattern, panel_name: str) -> None:
    for s in pattern.stitches:
        for side, attr in ((s.a, "length_a_cm"), (s.b, "length_b_cm")):
            if side.panel == panel_name and getattr(s, attr) is not None:
                setattr(s, attr, round(side_length_cm(pattern.panel(side.panel), side.range), _LENGTH_DIGITS))


def _check(before: Pattern, after: Pattern, where: str, what: str) -> None:
    had = set(validate_pattern(before).errors)
    new = [m for m in validate_pattern(after).errors if m not in had]
    if new:
        raise PatternError(f"{where}: {what} leaves an invalid pattern: {new[0]}")
