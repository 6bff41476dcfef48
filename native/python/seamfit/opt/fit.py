"""Fit measures a pattern maker reads: ease = garment girth minus body girth.

Girths are tape girths, as the bodies are measured: the perimeter of the convex hull
of the horizontal cross-section (a tape bridges hollows and folds).
"""
from __future__ import annotations

import numpy as np

from ..body.measure import _hull_perimeter, body_measurements, cross_section_girth


def mesh_cross_section(x: np.ndarray, triangles: np.ndarray, z: float) -> np.ndarray:
    """Points (k, 2) where the triangle edges of a 3D mesh cross the plane at height z."""
    x = np.asarray(x, dtype=float)
    tri = np.asarray(triangles)
    pts = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pa, pb = x[tri[:, a]], x[tri[:, b]]
        za, zb = pa[:, 2] - z, pb[:, 2] - z
        cross = (za * zb) < 0
        t = za[cross] / (za[cross] - zb[cross])
        pts.append(pa[cross, :2] + t[:, None] * (pb[cross, :2] - pa[cross, :2]))
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def garment_girth(x: np.ndarray, triangles: np.ndarray, z: float) -> float:
    """Tape girth (m) of the garment at height z, NaN where it does not reach."""
    pts = mesh_cross_section(x, triangles, z)
    if len(pts) < 3:
        return float("nan")
    return float(_hull_perimeter(pts))


def ease_report(body, x: np.ndarray, triangles: np.ndarray, levels: dict | None = None) -> dict:
    """Ease (cm) at bust, waist and hip: garment girth minus body girth at the body's own
    measuring levels. None where the garment does not cover that level."""
    if levels is None:
        levels = body_measurements(body)["levels_z_m"]
    out = {}
    for name in ("bust", "waist", "hip"):
        z = levels.get(name)
        if z is None:
            out[name] = None
            continue
        gg = garment_girth(x, triangles, z)
        bg = cross_section_girth(body, z)
        out[name] = None if not (np.isfinite(gg) and np.isfinite(bg)) else round(100.0 * (gg - bg), 2)
    return out
