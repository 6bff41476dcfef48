"""Seam allowance: the cutting line around a panel's seam line.

Each outline segment is pushed outward by the allowance of the edge that owns it (the
edge's ``seam_allowance_cm``, which the DXF reader measures from the file's cut line, or
a default for every edge without one). Consecutive offset segments of one edge meet where
their lines cross. At a corner, pattern makers either mitre (the offset lines run on to
where they cross, the allowance follows both seams into a point) or square (each seam's
allowance is carried past the corner by its own width and the two are joined by a
straight cut, so a sharp corner does not grow a long spike). A mitre longer than
``MITRE_LIMIT`` widths is squared all the same.

Known limit: where the seam line folds back tighter than the allowance (a dart's notch
in the outline), the offset lines overlap and the cut line crosses itself there.
"""
from __future__ import annotations

import numpy as np

from ..errors import PatternError
from .model import Panel

ALLOWANCE_CORNERS = ("mitre", "square")
MITRE_LIMIT = 4.0
_PARALLEL = 0.02                 # |sin| of a turn below which two offset lines are parallel


def segment_allowances(panel: Panel, default_cm: float | None) -> np.ndarray:
    """Allowance (cm) of every outline segment i -> i+1."""
    n = panel.n_vertices
    w = np.full(n, float(default_cm or 0.0))
    for e in panel.edges:
        width = e.extra.get("seam_allowance_cm")
        if width is None:
            continue
        try:
            width = float(width)
        except (TypeError, ValueError):
            raise PatternError(f"panel {panel.name!r} edge {e.id}: seam_allowance_cm must be a number") from None
        if not (np.isfinite(width) and width >= 0):
            raise PatternError(f"panel {panel.name!r} edge {e.id}: seam_allowance_cm must be >= 0")
        count = (e.end - e.start) % n or n
        w[(e.start + np.arange(count)) % n] = width
    return w


def cut_line(panel: Panel, default_cm: float | None = None, corners: str = "mitre") -> np.ndarray:
    """The cutting line (m, 2) in cm, same orientation as the outline."""
    if corners not in ALLOWANCE_CORNERS:
        raise PatternError(f"unknown corner style {corners!r} (expected {' or '.join(ALLOWANCE_CORNERS)})")
    o = np.asarray(panel.outline_cm, dtype=float)
    n = len(o)
    w = segment_allowances(panel, default_cm)
    d = np.roll(o, -1, axis=0) - o
    t = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    u, v = o[:, 0], o[:, 1]
    ccw = 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v)) > 0
    out_n = np.stack([t[:, 1], -t[:, 0]], axis=1) * (1.0 if ccw else -1.0)    # outward
    corner_set = set(panel.corners) | {e.start for e in panel.edges if _width_change(w, e.start, n)}
    pts: list[np.ndarray] = []
    for i in range(n):
        j = i - 1                               # incoming segment j, outgoing segment i
        a = o[i] + w[j] * out_n[j]
        b = o[i] + w[i] * out_n[i]
        if w[j] == 0 and w[i] == 0:
            pts.append(o[i].copy())
            continue
        sin = t[j, 0] * t[i, 1] - t[j, 1] * t[i, 0]
        convex = (sin > 0) == ccw               # a left turn on a ccw outline: an outward corner
        if abs(sin) < _PARALLEL:
            pts.extend([a, b] if np.linalg.norm(a - b) > 1e-9 else [a])
            continue
        hit = _cross(a, t[j], b, t[i])
        if i in corner_set and convex:
            if corners == "square" or np.linalg.norm(hit - o[i]) > MITRE_LIMIT * max(w[j], w[i]):
                pts.extend([a + w[j] * t[j], b - w[i] * t[i]])
                continue
        if i not in corner_set and np.linalg.norm(hit - o[i]) > MITRE_LIMIT * max(w[j], w[i], 1e-9):
            pts.extend([a, b])
            continue
        pts.append(hit)
    out = np.array(pts)
    keep = np.ones(len(out), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(out, axis=0), axis=1) > 1e-7
    return out[keep]


def _width_change(w: np.ndarray, i: int, n: int) -> bool:
    return w[(i - 1) % n] != w[i % n]


def _cross(p: np.ndarray, dp: np.ndarray, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """Where the lines p + s dp and q + r dq cross (not parallel)."""
    den = dp[0] * dq[1] - dp[1] * dq[0]
    s = ((q[0] - p[0]) * dq[1] - (q[1] - p[1]) * dq[0]) / den
    return p + s * dp
