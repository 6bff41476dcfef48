"""Mesh quality measures: triangle angles, sharp outline corners, area."""
from __future__ import annotations

import numpy as np

# A boundary vertex whose inside angle is below this is a sharp corner (a dart tip, a pointed
# collar): the triangles there cannot have a larger minimum angle than the corner itself.
SHARP_CORNER_DEG = 50.0


def triangle_angles_deg(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T, 3) angles in degrees at each triangle's three corners."""
    p = np.asarray(points, dtype=float)
    t = np.asarray(triangles)
    out = np.empty(t.shape, dtype=float)
    for k in range(3):
        a = p[t[:, k]]
        b = p[t[:, (k + 1) % 3]]
        c = p[t[:, (k + 2) % 3]]
        u, v = b - a, c - a
        cosang = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        out[:, k] = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    return out


def signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=float)[:, :2]
    a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def polygon_area(points: np.ndarray) -> float:
    u, v = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v))


def inside_angles_deg(loop_uv: np.ndarray) -> np.ndarray:
    """Inside angle of a closed polygon at each vertex (either orientation), in degrees."""
    p = np.asarray(loop_uv, dtype=float)
    sign = 1.0 if polygon_area(p) > 0 else -1.0
    to_prev = np.roll(p, 1, axis=0) - p
    to_next = np.roll(p, -1, axis=0) - p
    cross = to_next[:, 0] * to_prev[:, 1] - to_next[:, 1] * to_prev[:, 0]
    dot = np.einsum("ij,ij->i", to_next, to_prev)
    ang = np.degrees(np.arctan2(sign * cross, dot))
    return np.mod(ang, 360.0)


def sharp_vertices(loop_uv: np.ndarray, threshold_deg: float = SHARP_CORNER_DEG) -> np.ndarray:
    """Indices (into the loop) of vertices whose inside angle is below threshold_deg."""
    return np.nonzero(inside_angles_deg(loop_uv) < threshold_deg)[0]


def min_angles(points: np.ndarray, triangles: np.ndarray, sharp: np.ndarray) -> tuple[float, float]:
    """(min angle over all triangles, min angle over triangles touching no sharp vertex)."""
    ang = triangle_angles_deg(points, triangles).min(axis=1)
    mask = np.zeros(len(points), dtype=bool)
    mask[np.asarray(sharp, dtype=np.int64)] = True
    away = ~mask[triangles].any(axis=1)
    overall = float(ang.min()) if len(ang) else float("nan")
    interior = float(ang[away].min()) if away.any() else float("nan")
    return overall, interior
