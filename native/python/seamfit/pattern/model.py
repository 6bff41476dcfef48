"""The sewing pattern: panels with outlines, curves, landmarks and placement, and
the stitches that join them. Units follow ``sewpat-1``: outline in cm, placement in m.

Every class keeps the keys it does not interpret in ``extra`` so that reading and
writing a pattern is lossless.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

EDGE_KINDS = ("line", "quadratic", "cubic", "arc")


def by_garment_type(garment_type: str | None, rules, default: str) -> str:
    """The value of the first (substring, value) rule whose substring is in the garment type
    (case-insensitive), ``default`` when none is: how a pattern's free-form garment_type
    picks what suits its kind."""
    kind = (garment_type or "").lower()
    return next((value for key, value in rules if key in kind), default)


@dataclass
class Edge:
    """One source curve of a panel, running over outline indices start..end (wrapping)."""
    id: int
    start: int
    end: int
    kind: str                       # line | quadratic | cubic | arc
    p0: tuple[float, float]
    p1: tuple[float, float]
    ctrl: list[tuple[float, float]] = field(default_factory=list)  # Bezier control points
    arc: dict | None = None         # {"center", "radius", "angle0_rad", "angle1_rad"}
    length_cm: float | None = None
    label: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Placement:
    """Rigid placement of the flat panel in the world: world = R @ [0.01u, 0.01v, 0] + t."""
    kind: str                       # "exact" (GarmentCode) | "hint" (FreeSewing)
    rotation: np.ndarray            # (3, 3)
    translation_m: np.ndarray       # (3,)
    side: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_world(self, uv_cm: np.ndarray) -> np.ndarray:
        uv = 0.01 * np.asarray(uv_cm, dtype=float)
        r = np.asarray(self.rotation, dtype=float)
        # Elementwise, not a BLAS product: the start positions are then the same bits
        # under every BLAS kernel set (the drape's folds follow them).
        return uv[:, :1] * r[:, 0] + uv[:, 1:2] * r[:, 1] + np.asarray(self.translation_m, dtype=float)


@dataclass
class Panel:
    name: str
    outline_cm: np.ndarray          # (n, 2) closed polyline, last != first
    orientation: str                # "ccw" | "cw"
    nodes: list[int]
    corners: list[int]
    landmarks: dict[str, int]
    edges: list[Edge]
    placement: Placement
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def n_vertices(self) -> int:
        return len(self.outline_cm)

    def signed_area_cm2(self) -> float:
        u, v = self.outline_cm[:, 0], self.outline_cm[:, 1]
        with np.errstate(over="ignore", invalid="ignore"):   # absurd coordinates: inf, not a warning
            return 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v))


@dataclass
class StitchSide:
    panel: str
    range: tuple[int, int]          # outline indices i0..i1, forward, wrapping, both included
    edge: int | None = None
    landmarks: list[str] | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Stitch:
    kind: str
    a: StitchSide
    b: StitchSide
    orientation: str                # "reversed" | "same"
    gathered: bool = False
    length_a_cm: float | None = None
    length_b_cm: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Pattern:
    panels: list[Panel]
    stitches: list[Stitch]
    garment_type: str | None = None
    garment_id: str | None = None
    body_id: str | None = None
    fabric: dict[str, Any] = field(default_factory=dict)
    source_file: str | None = None  # where it was read from, for error messages
    extra: dict[str, Any] = field(default_factory=dict)

    def panel(self, name: str) -> Panel:
        for p in self.panels:
            if p.name == name:
                return p
        raise KeyError(f"pattern has no panel named {name!r}")

    def panel_index(self, name: str) -> int:
        for i, p in enumerate(self.panels):
            if p.name == name:
                return i
        raise KeyError(f"pattern has no panel named {name!r}")


def range_indices(side_range: tuple[int, int], n: int) -> np.ndarray:
    """Outline indices of a forward, wrapping range i0..i1 (both included)."""
    i0, i1 = side_range
    count = (i1 - i0) % n + 1
    return (i0 + np.arange(count)) % n


def polyline_length(points: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
