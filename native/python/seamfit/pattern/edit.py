"""Give some edges of a pattern new curves, as an artist edits them: the outline of every
changed edge is sampled again from its new curve and every outline index of the panel
(edge ranges, nodes, corners, landmarks, stitch ranges) follows its edge, so stitches stay
on the edges they join. Unchanged edges keep their outline points exactly.
"""
from __future__ import annotations

import copy
import math

import numpy as np

from ..errors import PatternError
from . import curves
from .model import Edge, Panel, Pattern
from .refit import side_length_cm

# sewpat-1 keeps outline samples at most 1 cm apart along every edge.
SAMPLE_SPACING_CM = 1.0
_LENGTH_DIGITS = 4              # lengths stored like the drafting conversions: 1e-4 cm
# Rounds of least squares and reparametrization when fitting a cubic to a drawn curve.
_N_REPARAM = 20


def edges_in_order(panel: Panel, where: str) -> list[Edge]:
    """The panel's edges in outline order; a PatternError unless they run end to start
    around the whole outline (then each outline point belongs to exactly one edge)."""
    n = panel.n_vertices
    order = sorted(panel.edges, key=lambda e: e.start)
    ok = bool(order) and all(order[k].end == order[(k + 1) % len(order)].start for k in range(len(order)))
    if not ok or sum((e.end - e.start) % n for e in order) != n:
        raise PatternError(f"{where}: its edges do not run end to start around the outline")
    return order


def edit_edges(pattern: Pattern, new_edges: dict[str, dict[int, Edge]],
               spacing_cm: float = SAMPLE_SPACING_CM) -> Pattern:
    """A copy of ``pattern`` in which edge ``id`` of panel ``name`` is ``new_edges[name][id]``
    (its kind and curve points; its outline range is recomputed). The input is not modified."""
    out = copy.deepcopy(pattern)
    changed = []
    for panel in out.panels:
        edits = new_edges.get(panel.name)
        if edits:
            where = f"{pattern.source_file or '<pattern>'}: panel {panel.name!r}"
            _apply(out, panel, edits, spacing_cm, where)
            changed.append(panel.name)
    for s in out.stitches:
        for side, attr in ((s.a, "length_a_cm"), (s.b, "length_b_cm")):
            if side.panel in changed and getattr(s, attr) is not None:
                setattr(s, attr, round(side_length_cm(out.panel(side.panel), side.range), _LENGTH_DIGITS))
    return out


def _apply(pattern: Pattern, panel: Panel, edits: dict[int, Edge], spacing_cm: float, where: str) -> None:
    old = np.asarray(panel.outline_cm, dtype=float)
    n = len(old)
    order = edges_in_order(panel, where)
    unknown = sorted(set(edits) - {e.id for e in order})
    if unknown:
        raise PatternError(f"{where}: has no edge {unknown[0]}")
    pts, new_index = [], np.empty(n, dtype=int)
    for e in order:
        m_old = (e.end - e.start) % n
        idx = (e.start + np.arange(m_old + 1)) % n
        start = len(pts)
        if e.id in edits:
            ne = edits[e.id]
            samples = curves.sample_by_length(ne, spacing_cm)
            m_new = len(samples) - 1
            # Points inside the edge keep their share of its length.
            seg = np.linalg.norm(np.diff(old[idx], axis=0), axis=1)
            frac = np.concatenate([[0.0], np.cumsum(seg)]) / max(float(seg.sum()), 1e-300)
            where_new = np.rint(frac * m_new).astype(int)
            pts.extend(samples[:-1])
            e.kind, e.p0, e.p1 = ne.kind, tuple(map(float, ne.p0)), tuple(map(float, ne.p1))
            e.ctrl = [tuple(map(float, c)) for c in ne.ctrl]
            e.arc = copy.deepcopy(ne.arc)
            if e.length_cm is not None:
                e.length_cm = round(curves.length(e), _LENGTH_DIGITS)
        else:
            where_new = np.arange(m_old + 1)
            pts.extend(old[idx[:-1]])
        new_index[idx[:-1]] = start + where_new[:-1]
        e.start = start
    total = len(pts)
    for k, e in enumerate(order):
        e.end = order[(k + 1) % len(order)].start
    new_index %= total

    def m(i: int) -> int:
        return int(new_index[i]) if 0 <= i < n else i      # out of range: validation reports it

    panel.outline_cm = np.asarray(pts, dtype=float).reshape(-1, 2)
    reindex(pattern, panel, m)


def reindex(pattern: Pattern, panel: Panel, m) -> None:
    """Move every outline index of ``panel`` held outside its edges (nodes, corners,
    landmarks, the stitch sides on it) through ``m`` (old index -> new index)."""
    panel.nodes = [m(i) for i in panel.nodes]
    panel.corners = [m(i) for i in panel.corners]
    panel.landmarks = {k: m(i) for k, i in panel.landmarks.items()}
    for s in pattern.stitches:
        for side in (s.a, s.b):
            if side.panel == panel.name:
                side.range = (m(side.range[0]), m(side.range[1]))


def arc_through(p0, p1, samples: np.ndarray) -> tuple[dict, float]:
    """The circular arc from ``p0`` to ``p1`` that best fits ``samples`` (points along the
    curve, in order): (``arc`` dict of an Edge, max distance in cm of the samples from it)."""
    p0, p1, q = np.asarray(p0, float), np.asarray(p1, float), np.asarray(samples, float)
    mid, chord = 0.5 * (p0 + p1), p1 - p0
    nrm = np.array([-chord[1], chord[0]]) / max(float(np.linalg.norm(chord)), 1e-300)
    # Centre on the chord's bisector, c = mid + s nrm: |q - c|^2 = |p0 - c|^2 is linear in s.
    a = 2.0 * (p0 - q) @ nrm
    b = (p0 @ p0) - np.einsum("ij,ij->i", q, q) - 2.0 * (p0 - q) @ mid
    s = float(a @ b / max(float(a @ a), 1e-300))
    c = mid + s * nrm
    r = float(np.linalg.norm(p0 - c))
    ang = np.unwrap(np.arctan2(*(np.concatenate([[p0], q, [p1]]) - c).T[::-1]))
    dev = float(np.abs(np.linalg.norm(q - c, axis=1) - r).max()) if len(q) else 0.0
    if not math.isfinite(r) or r > 1e6:
        return {}, math.inf
    return {"center": [float(c[0]), float(c[1])], "radius": r, "angle0_rad": float(ang[0]),
            "angle1_rad": float(ang[-1])}, dev


def cubic_through(p0, p1, samples: np.ndarray, t: np.ndarray | None = None) -> tuple[list, float]:
    """The cubic Bezier from ``p0`` to ``p1`` that best fits ``samples`` (points along the
    curve, in order; ``t`` their parameters if known, else by chord length to start):
    (its two control points, max distance in cm of the samples from it). Least squares for
    the control points, alternating with Newton steps to each sample's nearest parameter."""
    p0, p1, q = np.asarray(p0, float), np.asarray(p1, float), np.asarray(samples, float)
    if t is None:
        pts = np.concatenate([[p0], q, [p1]])
        d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        t = (d / max(float(d[-1]), 1e-300))[1:-1]
    t = np.asarray(t, float).copy()
    for _ in range(_N_REPARAM):
        b1, b2 = 3 * (1 - t) ** 2 * t, 3 * (1 - t) * t ** 2
        rhs = q - np.outer((1 - t) ** 3, p0) - np.outer(t ** 3, p1)
        c1, c2 = np.linalg.lstsq(np.stack([b1, b2], axis=1), rhs, rcond=None)[0]
        for _ in range(2):
            tt = t[:, None]
            pos = (1 - tt) ** 3 * p0 + 3 * (1 - tt) ** 2 * tt * c1 + 3 * (1 - tt) * tt ** 2 * c2 + tt ** 3 * p1
            d1 = 3 * (1 - tt) ** 2 * (c1 - p0) + 6 * (1 - tt) * tt * (c2 - c1) + 3 * tt ** 2 * (p1 - c2)
            d2 = 6 * (1 - tt) * (c2 - 2 * c1 + p0) + 6 * tt * (p1 - 2 * c2 + c1)
            num = np.einsum("ij,ij->i", pos - q, d1)
            den = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", pos - q, d2)
            t = np.clip(t - np.where(den > 1e-12, num / np.maximum(den, 1e-12), 0.0), 0.0, 1.0)
    edge = Edge(id=-1, start=0, end=1, kind="cubic", p0=tuple(p0), p1=tuple(p1), ctrl=[tuple(c1), tuple(c2)])
    dev = float(curves.distance_to_curve(edge, q).max()) if len(q) else 0.0
    return [tuple(map(float, c)) for c in (c1, c2)], dev
