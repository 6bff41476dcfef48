"""A measurement held as the mesh points it was taken at, to re-take it on a reshaped body.

``body_measurements(..., tapes=True)`` returns one :class:`Tape` per measurement: its
points as fixed combinations of vertices (``W @ V``), e.g. where the measuring plane
crossed an edge (vertex a, vertex b and the fraction t along the edge). On a body of the
same topology the same combinations give the corresponding points, so
``tape.length(V)`` re-takes the measurement in well under a millisecond without
slicing again. It is exact on the body it was
taken on and first-order accurate nearby: the levels of fullest girths are optimal, so
moving them changes the girth only to second order. Fitting a body to measurements
uses it for its Jacobians and then measures afresh.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix

__all__ = ["Tape"]


@dataclass
class Tape:
    """kind: "girth" (perimeter of the convex hull of the points in the plane spanned by
    ``basis``), "distance" (between points 0 and 1), "vertical" (mean height of the
    points before ``split`` minus that of the rest), "back" (length of the taut tape
    over the points' profile in the (y, z) plane, on the +y side)."""

    kind: str
    W: csr_matrix
    basis: np.ndarray | None = None
    split: int = 0

    @classmethod
    def on_edges(cls, kind: str, a, b, t, n_vertices: int, **kw) -> "Tape":
        """Points V[a] + t (V[b] - V[a])."""
        a, b, t = (np.asarray(x).ravel() for x in (a, b, t))
        rows = np.arange(len(a))
        W = csr_matrix((np.r_[1.0 - t, t], (np.r_[rows, rows], np.r_[a, b])), shape=(len(a), n_vertices))
        return cls(kind, W, **kw)

    @classmethod
    def at_vertices(cls, kind: str, vertices, n_vertices: int, **kw) -> "Tape":
        v = np.asarray(vertices, np.int64)
        return cls.on_edges(kind, v, v, np.zeros(len(v)), n_vertices, **kw)

    def points(self, V: np.ndarray) -> np.ndarray:
        return self.W @ V

    def length(self, V: np.ndarray) -> float:
        """The measurement (cm) on vertices V."""
        P = self.points(V)
        if self.kind == "girth":
            return 100.0 * hull_perimeter(P @ self.basis.T)
        if self.kind == "distance":
            return 100.0 * float(np.linalg.norm(P[1] - P[0]))
        if self.kind == "vertical":
            return 100.0 * float(P[:self.split, 2].mean() - P[self.split:, 2].mean())
        if self.kind == "back":
            return 100.0 * back_envelope_length(P[:, 1:])
        raise ValueError(f"unknown tape kind {self.kind!r}")


def hull_perimeter(pts: np.ndarray) -> float:
    """Perimeter of the convex hull of 2-D points."""
    from scipy.spatial import ConvexHull, QhullError   # here: importing seamfit.body stays light
    try:
        h = ConvexHull(pts)
    except (QhullError, ValueError):
        return 0.0
    p = pts[h.vertices]
    return float(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1).sum())


def back_envelope_length(yz: np.ndarray) -> float:
    """Length of the taut tape from the lowest to the highest of the (y, z) points on
    their +y side: the upper hull in y of the points ordered by z (monotone chain), so a
    hollow such as the small of the back is bridged."""
    order = np.lexsort((yz[:, 0], yz[:, 1]))
    pts = yz[order]
    chain: list = []
    for p in pts:
        # keep a right turn in (z, y): the chain bulges towards +y
        while len(chain) >= 2:
            (y1, z1), (y2, z2) = chain[-2], chain[-1]
            if (z2 - z1) * (p[0] - y1) - (y2 - y1) * (p[1] - z1) >= 0:
                chain.pop()
            else:
                break
        chain.append(p)
    c = np.array(chain)
    return float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum())
