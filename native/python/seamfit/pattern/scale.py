"""Proportional scaling of a pattern: the naive grading that multiplies widths by a girth
ratio and lengths by a height ratio.

It is the baseline a rule-free grading has to beat (besides the unchanged pattern):

* every panel is scaled by ``sx`` along its local u (across the body, widths) and by
  ``sy`` along v (along the body, lengths: the grain line, as all project patterns run);
* about the centre of the panel's outline bounding box, so the placement still puts the
  panel where it was (``world = R @ 0.01 uv + t`` maps that centre to the same point);
* the scaled outlines go through :func:`refit_pattern`, so every edge curve is refitted
  (a circle arc scaled unevenly is an ellipse arc: it becomes a cubic when no arc fits),
  and stitch lengths are updated.

Which girth sets ``sx`` (:func:`girth_for_garment`): bust for tops (bodice, shirt), waist
for circle skirts (only the waist fits the body; the flare is a design length), hip for
everything else below the waist (pencil skirts, trousers).
"""
from __future__ import annotations

import numpy as np

from .model import Pattern, by_garment_type
from .refit import refit_pattern

# garment_type substrings -> girth that sets the horizontal ratio; first match wins
_GIRTH_RULES = (("circle", "waist"), ("bodice", "bust"), ("shirt", "bust"), ("top", "bust"),
                ("dress", "bust"), ("skirt", "hip"), ("pants", "hip"), ("trouser", "hip"))


def girth_for_garment(garment_type: str | None) -> str:
    """The body girth ('bust' | 'waist' | 'hip') whose ratio scales widths of this garment."""
    return by_garment_type(garment_type, _GIRTH_RULES, "hip")


def scale_outline(outline_cm: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """The outline scaled by (sx, sy) about the centre of its bounding box."""
    o = np.asarray(outline_cm, dtype=float)
    c = 0.5 * (o.min(axis=0) + o.max(axis=0))
    return c + (o - c) * np.array([sx, sy])


def scale_pattern(pattern: Pattern, sx: float, sy: float) -> Pattern:
    """A new pattern with every panel scaled by ``sx`` in u and ``sy`` in v (see the module
    docstring); ``pattern`` is not modified."""
    if not (sx > 0 and sy > 0 and np.isfinite(sx) and np.isfinite(sy)):
        raise ValueError(f"scale factors must be finite and > 0, got sx={sx}, sy={sy}")
    moved = {p.name: scale_outline(p.outline_cm, sx, sy) for p in pattern.panels}
    return refit_pattern(pattern, moved).pattern


def proportional_ratios(garment_type: str | None, base_cm: dict, target_cm: dict) -> dict:
    """{'girth', 'sx', 'sy'}: the girth ratio (target / base) for widths and the stature
    ratio for lengths, from two measurement dicts in cm (keys bust, waist, hip, height)."""
    girth = girth_for_garment(garment_type)
    return {"girth": girth, "sx": float(target_cm[girth]) / float(base_cm[girth]),
            "sy": float(target_cm["height"]) / float(base_cm["height"])}


def proportional_scale(pattern: Pattern, base_cm: dict, target_cm: dict) -> tuple[Pattern, dict]:
    """The pattern scaled by :func:`proportional_ratios` and the ratios used."""
    r = proportional_ratios(pattern.garment_type, base_cm, target_cm)
    return scale_pattern(pattern, r["sx"], r["sy"]), r
