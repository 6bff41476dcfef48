"""Exact closest points on a triangle mesh, for registration and its error report.

A k-d tree holds points sampled on every triangle, each within a radius r of every
point of its part of the triangle. The nearest sample's triangle gives a bound b on a
query point's distance; the closest point has a sample of its triangle within r, so
within b + r of the query: the triangles of the samples in that ball hold the answer.
"""
from __future__ import annotations

import numpy as np

__all__ = ["SurfaceIndex", "area_samples", "closest_on_triangles", "subdivision_centroids"]


def closest_on_triangles(P, A, B, C) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of triangles (A, B, C) to points P (all (n, 3)), and their
    barycentric coordinates (n, 3); the region tests of Ericson, Real-Time Collision
    Detection 5.1.5, vectorised."""
    ab, ac, ap = B - A, C - A, P - A
    d1 = np.einsum("ij,ij->i", ab, ap)
    d2 = np.einsum("ij,ij->i", ac, ap)
    bp = P - B
    d3 = np.einsum("ij,ij->i", ab, bp)
    d4 = np.einsum("ij,ij->i", ac, bp)
    cp = P - C
    d5 = np.einsum("ij,ij->i", ab, cp)
    d6 = np.einsum("ij,ij->i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    bary = np.zeros((len(P), 3))
    done = np.zeros(len(P), bool)

    def put(mask, u, v, w):
        m = mask & ~done
        bary[m, 0], bary[m, 1], bary[m, 2] = u[m] if np.ndim(u) else u, v[m] if np.ndim(v) else v, \
            w[m] if np.ndim(w) else w
        done[m] = True

    with np.errstate(divide="ignore", invalid="ignore"):
        put((d1 <= 0) & (d2 <= 0), 1.0, 0.0, 0.0)                       # vertex A
        put((d3 >= 0) & (d4 <= d3), 0.0, 1.0, 0.0)                      # vertex B
        put((d6 >= 0) & (d5 <= d6), 0.0, 0.0, 1.0)                      # vertex C
        t = d1 / (d1 - d3)
        put((vc <= 0) & (d1 >= 0) & (d3 <= 0), 1 - t, t, np.zeros_like(t))          # edge AB
        t = d2 / (d2 - d6)
        put((vb <= 0) & (d2 >= 0) & (d6 <= 0), 1 - t, np.zeros_like(t), t)          # edge AC
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        put((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), np.zeros_like(t), 1 - t, t)  # edge BC
        denom = va + vb + vc
        v, w = vb / denom, vc / denom
        put(np.ones(len(P), bool), 1 - v - w, v, w)                     # the face
    bad = ~np.isfinite(bary).all(axis=1)          # a degenerate triangle: its nearest corner
    if bad.any():
        corners = np.stack([A[bad], B[bad], C[bad]], axis=1)
        k = np.argmin(np.linalg.norm(corners - P[bad, None], axis=2), axis=1)
        bary[bad] = np.eye(3)[k]
    Q = bary[:, :1] * A + bary[:, 1:2] * B + bary[:, 2:] * C
    return Q, bary


def subdivision_centroids(T: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The centroids of triangle t's n[t] x n[t] similar sub-triangles (T: (m, 3, 3)),
    and the triangle of each."""
    pts, tri = [], []
    for m in np.unique(n):
        sel = np.flatnonzero(n == m)
        i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
        up = i + j <= m - 1                       # sub-triangles pointing like the triangle
        down = i + j <= m - 2                     # and those pointing the other way
        w = np.concatenate([
            np.stack([m - i[up] - j[up] - 2 / 3, i[up] + 1 / 3, j[up] + 1 / 3], axis=1),
            np.stack([m - i[down] - j[down] - 4 / 3, i[down] + 2 / 3, j[down] + 2 / 3], axis=1)]) / m
        pts.append(np.einsum("sk,tkd->tsd", w, T[sel]).reshape(-1, 3))
        tri.append(np.repeat(sel, len(w)))
    return np.concatenate(pts), np.concatenate(tri)


def area_samples(vertices, faces, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points spread over the surface by area, about one per spacing^2 (at most one per
    spacing^2 / 2): each triangle cut into sub-triangles of at most that area, whatever
    its shape (a sliver gets few). Returns the points, their triangles and the area each
    stands for."""
    V = np.asarray(vertices, dtype=np.float64)
    T = V[np.asarray(faces, dtype=np.int64)]
    area = 0.5 * np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
    n = np.maximum(1, np.ceil(np.sqrt(2.0 * area) / spacing)).astype(np.int64)
    P, tri = subdivision_centroids(T, n)
    return P, tri, area[tri] / n[tri] ** 2


class SurfaceIndex:
    """Closest-point queries on one triangle mesh (vertices (n, 3), faces (m, 3))."""

    def __init__(self, vertices, faces, spacing: float | None = None):
        from scipy.spatial import cKDTree     # here: importing seamfit.body stays light
        self.V = np.asarray(vertices, dtype=np.float64)
        self.F = np.asarray(faces, dtype=np.int64)
        T = self.V[self.F]
        edges = np.linalg.norm(T - T[:, [1, 2, 0]], axis=2)
        reach = np.linalg.norm(T - T.mean(axis=1, keepdims=True), axis=2).max(axis=1)
        # Each triangle cut into n x n similar sub-triangles (n = longest edge / spacing,
        # half the mesh's median edge by default), sampled at their centroids: a sample is
        # within reach / n of every point of its sub-triangle.
        h = float(spacing or 0.5 * np.median(edges))
        n = np.maximum(1, np.ceil(edges.max(axis=1) / h)).astype(np.int64)
        self.radius = float((reach / n).max())
        self.samples, self.sample_tri = subdivision_centroids(T, n)
        self.tree = cKDTree(self.samples)

    def query(self, P, within: float = np.inf) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per point: distance, closest triangle, closest point and its barycentric coordinates.
        With ``within``, a point farther than that from the surface is only known to be: it
        gets some triangle's distance (over ``within``) and point, not the closest one's.
        Fits that drop far matches need no more, and far points (arms in another pose) would
        otherwise search thousands of samples."""
        P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
        n = len(P)
        if n == 0:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
        # An upper bound first: the distance to the nearest sample's triangle.
        _, s = self.tree.query(P, k=1, workers=-1)
        first = self.sample_tri[s]
        bound = self._nearest(P, np.arange(n), first, n)[0]
        # Every triangle that can be nearer (or within ``within``) has a sample in this ball
        # (module docstring); a point farther than ``within`` keeps its bound.
        balls = self.tree.query_ball_point(P, np.minimum(bound, within) + self.radius, workers=-1,
                                           return_sorted=False)
        counts = np.fromiter(map(len, balls), np.int64, n)
        rows = np.r_[np.arange(n), np.repeat(np.arange(n), counts)]
        tris = np.r_[first, self.sample_tri[np.concatenate([np.zeros(0, np.int64), *balls]).astype(np.int64)]]
        pairs = np.unique(rows * len(self.F) + tris)
        return self._nearest(P, pairs // len(self.F), pairs % len(self.F), n)

    def _nearest(self, P, rows, tris, n):
        """Per point of P, the nearest of the (rows, tris) pairs' triangles, the lowest
        triangle on a tie (inf where none)."""
        F = self.F[tris]
        Q, bary = closest_on_triangles(P[rows], self.V[F[:, 0]], self.V[F[:, 1]], self.V[F[:, 2]])
        d = np.linalg.norm(P[rows] - Q, axis=1)
        order = np.lexsort((tris, d, rows))
        head = order[np.r_[True, rows[order][1:] != rows[order][:-1]]]   # each row's nearest
        best_d = np.full(n, np.inf)
        best_t = np.zeros(n, np.int64)
        best_q = np.zeros((n, 3))
        best_b = np.zeros((n, 3))
        r = rows[head]
        best_d[r], best_t[r], best_q[r], best_b[r] = d[head], tris[head], Q[head], bary[head]
        return best_d, best_t, best_q, best_b
