"""Truing the darts of a graded outline: both legs of a straight dart as long as the base
pattern had them (equal, almost always).

The search keeps every stitch's two sides equally long along the moved outline (R^seam),
but a straight dart leg that the search bent a little is refitted as a straight line, and
a line is its chord: two legs bent by different amounts come out of the refit unequal (a
fitted bodice on a body with a belly: 3 mm). A pattern maker trues such a dart by moving
the legs' open ends along the legs until they match; so does this module, before the
refit, moving each open end by half the difference and carrying the neighbouring edge
along with a move that fades to nothing at its far end.
"""
from __future__ import annotations

import numpy as np

from .model import Pattern, range_indices

__all__ = ["dart_stitches", "true_darts"]


def _edge_kinds_over(panel, idx: np.ndarray) -> set[str]:
    """Kinds of the edges that cover the outline indices idx (a forward run)."""
    n = panel.n_vertices
    kinds = set()
    steps = {frozenset(p) for p in zip(idx[:-1].tolist(), idx[1:].tolist())}
    for e in panel.edges:
        run = range_indices((e.start, e.end), n)
        if steps & {frozenset(p) for p in zip(run[:-1].tolist(), run[1:].tolist())}:
            kinds.add(e.kind)
    return kinds


def dart_stitches(base: Pattern) -> list[dict]:
    """Every straight dart of ``base``: a non-gathered stitch joining two runs of one
    panel's outline that meet at one point (the tip), both covered by line edges. Per dart:
    the panel, the tip index, each leg's open end and its outline indices (tip first), and
    the base's chord lengths."""
    darts = []
    for k, s in enumerate(base.stitches):
        if s.gathered or s.a.panel != s.b.panel:
            continue
        panel = base.panel(s.a.panel)
        n = panel.n_vertices
        ia, ib = range_indices(s.a.range, n), range_indices(s.b.range, n)
        if len(ia) < 2 or len(ib) < 2:
            continue
        if ia[-1] == ib[0] and ia[0] != ib[-1]:
            tip, leg_a, leg_b = int(ia[-1]), ia[::-1], ib
        elif ib[-1] == ia[0] and ib[0] != ia[-1]:
            tip, leg_a, leg_b = int(ia[0]), ia, ib[::-1]
        else:
            continue
        if _edge_kinds_over(panel, ia) - {"line"} or _edge_kinds_over(panel, ib) - {"line"}:
            continue
        o = np.asarray(panel.outline_cm, dtype=float)
        darts.append({"stitch": k, "panel": panel.name, "tip": tip,
                      "legs": (leg_a, leg_b),
                      "base_lengths": (float(np.linalg.norm(o[leg_a[-1]] - o[tip])),
                                       float(np.linalg.norm(o[leg_b[-1]] - o[tip])))})
    return darts


def _neighbour_run(panel, end: int, leg: np.ndarray) -> np.ndarray:
    """Outline indices of the edge that meets the leg at its open end, from that end to the
    edge's far end."""
    n = panel.n_vertices
    for e in panel.edges:
        run = range_indices((e.start, e.end), n)
        if len(run) < 2 or int(leg[-2]) in run.tolist():
            continue
        if run[0] == end:
            return run
        if run[-1] == end:
            return run[::-1]
    return np.array([end])


def true_darts(base: Pattern, outlines: dict[str, np.ndarray]) -> dict[str, float]:
    """Moves, in place, the open ends of every straight dart's legs in ``outlines`` (panel ->
    (n, 2) cm, the base's point order) so the legs' chords differ as in the base. Returns the
    largest move per panel, mm (panels with no dart are left out)."""
    moved: dict[str, float] = {}
    for d in dart_stitches(base):
        name = d["panel"]
        if name not in outlines:
            continue
        panel = base.panel(name)
        o = outlines[name]
        tip = o[d["tip"]].copy()
        lengths = [float(np.linalg.norm(o[leg[-1]] - tip)) for leg in d["legs"]]
        if min(lengths) <= 0:
            continue
        mean, diff0 = 0.5 * sum(lengths), d["base_lengths"][0] - d["base_lengths"][1]
        targets = (mean + 0.5 * diff0, mean - 0.5 * diff0)
        for leg, length, target in zip(d["legs"], lengths, targets):
            end = int(leg[-1])
            u = (o[end] - tip) / length
            delta = (target - length) * u
            # the leg stretches along itself, tip fixed
            o[leg[1:]] = tip + (o[leg[1:]] - tip) * (target / length)
            # the edge beyond the open end follows, fading out towards its far end (which
            # stays); the open end itself moved with the leg
            run = _neighbour_run(panel, end, leg)
            if len(run) > 2:
                s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(o[run], axis=0), axis=1))])
                if s[-1] > 0:
                    w = 1.0 - s / s[-1]
                    o[run[1:-1]] += w[1:-1, None] * delta
            moved[name] = max(moved.get(name, 0.0), 10.0 * float(np.linalg.norm(delta)))
    return moved
