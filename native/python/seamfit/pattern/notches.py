"""Notches compared across a seam: the two sides of a stitch carry their notches at the
same arc length from where the sides meet, or the pieces are sewn out of step.

A notch is an outline vertex listed in a panel's ``notches`` (its name: the landmark
``notch_<k>`` on that vertex). Along a stitch, side a is read from its start and side b
from the point that meets a's start (b's end for ``reversed``, its start for ``same``); a
gathered side b is read scaled to side a's length, since gathering spreads it evenly.
Notches at a side's own ends (its corners) are not compared.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Panel, range_indices

NOTCH_MATCH_CM = 1.0             # notches of two sides line up within this arc length


@dataclass
class NotchMiss:
    """A notch on one side with no partner on the other within ``NOTCH_MATCH_CM``."""
    side: str                    # 'a' or 'b'
    panel: str
    notch: str                   # its landmark name, e.g. 'notch_2'
    at_cm: float                 # arc length from where the sides meet
    other_panel: str
    nearest: tuple[str, float] | None    # the other side's nearest notch, if any

    def describe(self) -> str:
        near = ("it has no notches" if self.nearest is None
                else f"its nearest, {self.nearest[0]}, is at {self.nearest[1]:.2f} cm")
        return (f"{self.notch} of panel {self.panel!r} (side {self.side}) sits {self.at_cm:.2f} cm along the seam, "
                f"but side {'b' if self.side == 'a' else 'a'} (panel {self.other_panel!r}) has no notch within "
                f"{NOTCH_MATCH_CM:g} cm of that; {near}")


def _names(panel: Panel) -> dict[int, str]:
    names = {}
    notches = panel.extra.get("notches")
    for k, entry in enumerate(notches if isinstance(notches, list) else []):
        v = entry.get("vertex") if isinstance(entry, dict) else None
        if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
            names[int(v)] = f"notch_{k}"
    for name, v in panel.landmarks.items():      # the landmark's own name, where it has one
        if isinstance(v, (int, np.integer)) and int(v) in names and str(name).startswith("notch"):
            names[int(v)] = name
    return names


def side_notches(panel: Panel, side_range: tuple[int, int]) -> tuple[list[tuple[str, float]], float]:
    """The notches inside a side, as (name, arc length from the side's start in cm), and
    the side's length."""
    o = np.asarray(panel.outline_cm, dtype=float)
    idx = range_indices(side_range, len(o))
    pts = o[idx]
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    names = _names(panel)
    inner = {int(v): float(c) for v, c in zip(idx[1:-1], cum[1:-1])}
    found = sorted(((names[v], s) for v, s in inner.items() if v in names), key=lambda t: t[1])
    return found, float(cum[-1])


def notch_misses(pa: Panel, range_a, pb: Panel, range_b, *, orientation: str = "reversed",
                 gathered: bool = False) -> list[NotchMiss]:
    """Each notch of either side with no partner on the other (each notch partners one)."""
    na, la = side_notches(pa, range_a)
    nb, lb = side_notches(pb, range_b)
    if not na and not nb:
        return []
    k = la / lb if gathered and lb > 0 else 1.0
    nb = sorted(((name, k * ((lb - s) if orientation == "reversed" else s)) for name, s in nb), key=lambda t: t[1])
    # pair closest first, so that one stray notch does not take another's partner
    pairs = sorted((abs(sa - sb), i, j) for i, (_, sa) in enumerate(na) for j, (_, sb) in enumerate(nb))
    used_a, used_b = set(), set()
    for d, i, j in pairs:
        if d <= NOTCH_MATCH_CM and i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
    out = []
    for tag, mine, other, used, p, q in (("a", na, nb, used_a, pa, pb), ("b", nb, na, used_b, pb, pa)):
        for i, (name, s) in enumerate(mine):
            if i in used:
                continue
            nearest = min(other, key=lambda t: abs(t[1] - s)) if other else None
            out.append(NotchMiss(tag, p.name, name, s, q.name, nearest))
    return out
