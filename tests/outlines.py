"""Panel outlines (cm) in tests: another size made by scaling, how far one outline's points
lie from another, and the point that lines two sizes of a panel up."""
from __future__ import annotations

import copy

import numpy as np


def polyline_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Each point's distance to the closed polyline ``poly``."""
    points = np.asarray(points, dtype=float)
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    t = np.clip(np.einsum("pij,ij->pi", points[:, None, :] - a[None], ab) / ab2, 0, 1)
    return np.linalg.norm(a[None] + t[..., None] * ab[None] - points[:, None, :], axis=-1).min(axis=1)


def outline_gap(a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance from a point of either closed outline to the other outline."""
    return float(max(polyline_distance(a, b).max(), polyline_distance(b, a).max()))


def anchor(outline: np.ndarray) -> np.ndarray:
    """The middle of the outline's top edge (of its bounding box): where graded sizes are
    lined up before their outlines are compared."""
    return np.array([0.5 * (outline[:, 0].min() + outline[:, 0].max()), outline[:, 1].max()])


def scaled_pattern(pattern, f):
    """A copy of the pattern with every panel scaled by f (a number, or (across, along)):
    its outline, its curves (the cut lines are rebuilt from them) and its grain line."""
    p = copy.deepcopy(pattern)
    f = np.broadcast_to(np.asarray(f, dtype=float), (2,))
    for panel in p.panels:
        panel.outline_cm = panel.outline_cm * f
        for e in panel.edges:
            e.p0, e.p1 = tuple(np.multiply(e.p0, f)), tuple(np.multiply(e.p1, f))
            e.ctrl = [tuple(np.multiply(c, f)) for c in e.ctrl]
        if panel.extra.get("grain_line_cm"):
            panel.extra["grain_line_cm"] = (np.asarray(panel.extra["grain_line_cm"]) * f).tolist()
    return p
