"""Symmetry of a pattern kept through grading.

Two kinds are found in the base pattern, each within ``TOL_CM`` (0.1 mm) on every outline
point:

* a panel symmetric about its own centre line (vertical or horizontal, through its
  bounding box's centre): a whole front cut on the fold, a waistband;
* a left/right pair: two panels with as many points, one the mirror image (u -> -u) of the
  other, up to a shift.

The grading moves each point on its own, so neither survives exactly (the bodies and the
drape are not perfectly symmetric). ``symmetrize`` puts it back on the graded outlines
before their curves are refitted: a symmetric panel becomes the mean of itself and its
mirror image about its fitted centre line; a pair becomes the mean of the one and the
other's mirror image, each placed where its graded copy lies.
"""
from __future__ import annotations

import numpy as np

TOL_CM = 0.01


def _partner(a: np.ndarray, b: np.ndarray, tol: float):
    """Index map j with b[j[i]] == a[i] within tol (a bijection), or None."""
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    j = np.argmin(d, axis=1)
    if float(d[np.arange(len(a)), j].max()) > tol or len(set(j.tolist())) != len(a):
        return None
    return j


def _mirror(o: np.ndarray, axis: int, c: float) -> np.ndarray:
    m = o.copy()
    m[:, axis] = 2.0 * c - m[:, axis]
    return m


def find_symmetries(pattern, tol_cm: float = TOL_CM) -> list[dict]:
    """The symmetric panels and left/right pairs of ``pattern`` (see the module's text):
    dicts with kind "panel" (panel, axis 0: about a vertical line, 1: horizontal; partner
    index map) or "pair" (a, b, partner map from a's points to b's)."""
    out = []
    paired: set[str] = set()
    panels = list(pattern.panels)
    for p in panels:
        o = np.asarray(p.outline_cm, dtype=float)
        if len(o) > 4000:
            continue                       # the distance table would be too large; such panels are rare
        for axis in (0, 1):
            c = 0.5 * (o[:, axis].min() + o[:, axis].max())
            j = _partner(o, _mirror(o, axis, c), tol_cm)
            if j is not None:
                out.append({"kind": "panel", "panel": p.name, "axis": axis, "partner": j})
                break
    # Two equal panels each symmetric in itself (a circle skirt's front and back) are not a
    # left/right pair: their bodies' front and back may grade apart.
    paired = {s["panel"] for s in out}
    for i, p in enumerate(panels):
        for q in panels[i + 1:]:
            if p.name in paired or q.name in paired or len(p.outline_cm) != len(q.outline_cm):
                continue
            if not _opposite_sides(p, q):
                continue
            a, b = np.asarray(p.outline_cm, dtype=float), np.asarray(q.outline_cm, dtype=float)
            if len(a) > 4000:
                continue
            m = _mirror(a, 0, 0.0)
            m = m - m.mean(axis=0) + b.mean(axis=0)
            j = _partner(m, b, tol_cm)
            if j is not None:
                out.append({"kind": "pair", "a": p.name, "b": q.name, "partner": j})
                paired |= {p.name, q.name}
    return out


def _opposite_sides(p, q) -> bool:
    """Placed on opposite sides of the body's centre plane (x = 0), where both are placed
    off it; panels without a placement off the centre may pair on shape alone."""
    xs = []
    for panel in (p, q):
        t = getattr(getattr(panel, "placement", None), "translation_m", None)
        xs.append(None if t is None else float(np.asarray(t, dtype=float)[0]))
    if None in xs or min(abs(x) for x in xs) < 0.01:
        return True
    return xs[0] * xs[1] < 0


def _fit_axis_line(o: np.ndarray, j: np.ndarray, axis: int):
    """The centre line a graded panel is (nearly) symmetric about: in the base's direction
    (the panels are turned back onto the base's grain), through the mean of the pairs'
    midpoints. Returns (point, unit normal)."""
    return (0.5 * (o + o[j])).mean(axis=0), np.eye(2)[axis]


def _reflect(o: np.ndarray, c: np.ndarray, n: np.ndarray) -> np.ndarray:
    return o - 2.0 * ((o - c) @ n)[:, None] * n[None, :]


def symmetry_error_cm(pattern, sym: dict) -> float:
    """How far (cm) the pattern is from the symmetry ``sym`` found in its base: the largest
    distance of a point from its partner's mirror image."""
    panels = {p.name: np.asarray(p.outline_cm, dtype=float) for p in pattern.panels}
    j = np.asarray(sym["partner"])
    if sym["kind"] == "panel":
        o = panels[sym["panel"]]
        c, n = _fit_axis_line(o, j, sym["axis"])
        return float(np.linalg.norm(_reflect(o, c, n)[j] - o, axis=1).max())
    a, b = panels[sym["a"]], panels[sym["b"]]
    m = _mirror(a, 0, 0.0)
    m = m - m.mean(axis=0) + b.mean(axis=0)
    return float(np.linalg.norm(m - b[j], axis=1).max())


def symmetrize(outlines: dict, symmetries: list[dict]) -> dict:
    """Put each symmetry back on graded outlines (panel name -> (n, 2) cm), in place.
    Returns per panel the largest move (mm) it took."""
    moved = {}
    for sym in symmetries:
        j = np.asarray(sym["partner"])
        if sym["kind"] == "panel":
            name = sym["panel"]
            if name not in outlines:
                continue
            o = np.asarray(outlines[name], dtype=float)
            c, n = _fit_axis_line(o, j, sym["axis"])
            new = 0.5 * (o + _reflect(o, c, n)[j])
            moved[name] = round(10.0 * float(np.linalg.norm(new - o, axis=1).max()), 4)
            outlines[name] = new
        else:
            if sym["a"] not in outlines or sym["b"] not in outlines:
                continue
            a = np.asarray(outlines[sym["a"]], dtype=float)
            b = np.asarray(outlines[sym["b"]], dtype=float)
            ca, cb = a.mean(axis=0), b.mean(axis=0)
            # b's points in a's order, mirrored back onto a's side and place
            inv = np.empty_like(j)
            inv[j] = np.arange(len(j))
            b_as_a = _mirror(b[j], 0, 0.0)
            b_as_a = b_as_a - b_as_a.mean(axis=0) + ca
            new_a = 0.5 * (a + b_as_a)
            new_b = _mirror(new_a, 0, 0.0)
            new_b = new_b - new_b.mean(axis=0) + cb
            new_b = new_b[inv]
            moved[sym["a"]] = round(10.0 * float(np.linalg.norm(new_a - a, axis=1).max()), 4)
            moved[sym["b"]] = round(10.0 * float(np.linalg.norm(new_b - b, axis=1).max()), 4)
            outlines[sym["a"]], outlines[sym["b"]] = new_a, new_b
    return moved


def symmetry_report(pattern, symmetries: list[dict], moved_mm: dict) -> dict:
    """The report's ``symmetry`` entry: each symmetry found in the base, how far the graded
    outline was moved to keep it (mm) and how far the written pattern is from it (mm)."""
    out = []
    for sym in symmetries:
        names = [sym["panel"]] if sym["kind"] == "panel" else [sym["a"], sym["b"]]
        out.append({"kind": sym["kind"], "panels": names,
                    **({"axis": "vertical" if sym["axis"] == 0 else "horizontal"} if sym["kind"] == "panel" else {}),
                    "moved_mm": max((moved_mm.get(n, 0.0) for n in names), default=0.0),
                    "error_mm": round(10.0 * symmetry_error_cm(pattern, sym), 4)})
    return {"found": out, "max_error_mm": max((s["error_mm"] for s in out), default=0.0)}
