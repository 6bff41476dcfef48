"""Truing circle skirts: a panel drafted as an annular sector comes out as one.

A circle skirt's panel is a sector of a ring: a waist arc and a hem arc about one centre,
joined by two straight radial seams. The search moves its outline point by point, so the
graded waist is a near-circle that is wider across than along (the GarmentCode circle skirt
on size 16: 0.86 cm from its draft), and its fullness drifts. A pattern maker grading a
circle skirt keeps its angle (the style: a full, half or quarter circle) and sets the waist
radius from the waist it must fit and the length from the skirt's length. So does this
module, before the refit: the angle stays the base's, the waist radius is the one whose arc
is as long as the graded waist (which the search fitted to the body and to any waistband),
the radial length is the mean of the graded side seams, and every outline point keeps its
base polar coordinates about the centre, scaled along the radius. The hem follows from
those, so a panel is trued only when its hem is free (stitched to nothing). Measured in
docs/method.md ("Circle skirts trued to annular sectors").
"""
from __future__ import annotations

import math

import numpy as np

from .compare import rigid_fit
from .model import Pattern, Panel, polyline_length, range_indices

__all__ = ["fit_circle", "annular_sectors", "true_sectors"]

# A run of outline points is an arc when its rms distance from its circle is below this
# share of the radius; a point lies on the sector's centre line (a radial seam) when its
# direction from the centre is within this many radians of the seam's.
ARC_RMS_REL = 1e-3
RADIAL_TOL_RAD = 1e-3
# The two radial seams must agree this closely (cm) to be trued to one length: more and
# the panel was graded into something other than a sector, and is left as it is.
SIDE_MISMATCH_CM = 0.2


def fit_circle(uv: np.ndarray):
    """Least-squares circle (Kasa): centre (2,), radius, rms residual.

    Solved in closed form from correctly rounded sums (math.fsum) about the points'
    mean, not by LAPACK: the same bits under every BLAS kernel set (a circle skirt's
    base drape, which starts from such a circle, differed by up to 9 cm between two)."""
    uv = np.asarray(uv, dtype=np.float64)
    m = np.array([math.fsum(uv[:, 0]) / len(uv), math.fsum(uv[:, 1]) / len(uv)])
    u, v = uv[:, 0] - m[0], uv[:, 1] - m[1]
    w = -(u * u + v * v)
    # Normal equations of [u v 1] s = w; centred, the constant column decouples.
    suu, svv, suv = math.fsum(u * u), math.fsum(v * v), math.fsum(u * v)
    suw, svw = math.fsum(u * w), math.fsum(v * w)
    det = suu * svv - suv * suv
    if not det > 0:
        return m, math.inf, math.inf
    d_u = (suw * svv - svw * suv) / det
    d_v = (svw * suu - suw * suv) / det
    f = math.fsum(w) / len(uv)
    c = np.array([-0.5 * d_u, -0.5 * d_v])
    r2 = c[0] * c[0] + c[1] * c[1] - f
    c = c + m
    if not (r2 > 0):
        return c, math.inf, math.inf
    r = math.sqrt(r2)
    return c, r, float(np.sqrt(np.mean((np.linalg.norm(uv - c, axis=1) - r) ** 2)))


def _edge_run(panel: Panel, e) -> np.ndarray:
    return range_indices((e.start, e.end), panel.n_vertices)


def _sector_of(panel: Panel) -> dict | None:
    """The annular sector ``panel`` is drafted as, or None: its centre, inner and outer
    radius, the outline runs of its inner arc, outer arc and two radial seams."""
    o = np.asarray(panel.outline_cm, dtype=float)
    arcs, lines = [], []
    for e in panel.edges:
        run = _edge_run(panel, e)
        if len(run) >= 3:
            c, r, rms = fit_circle(o[run])
            chord = float(np.linalg.norm(o[run[-1]] - o[run[0]]))
            if math.isfinite(r) and rms <= ARC_RMS_REL * r and r < 50.0 * max(chord, 1e-9):
                arcs.append((c, r, run))
                continue
        lines.append(run)
    if len(arcs) < 2 or len(lines) != 2:
        return None
    centre = arcs[0][0]
    r_ref = max(a[1] for a in arcs)
    if any(np.linalg.norm(a[0] - centre) > 10 * ARC_RMS_REL * r_ref for a in arcs):
        return None
    radii = sorted({a[1] for a in arcs})
    r_in, r_out = radii[0], radii[-1]
    tol = 10 * ARC_RMS_REL * r_out
    inner = [a[2] for a in arcs if abs(a[1] - r_in) <= tol]
    outer = [a[2] for a in arcs if abs(a[1] - r_out) <= tol]
    if len(inner) + len(outer) != len(arcs) or r_out - r_in <= tol:
        return None
    for run in lines:   # each seam runs straight out from the centre, inner arc to outer
        d = o[run] - centre
        ang = np.arctan2(d[:, 1], d[:, 0])
        rad = np.linalg.norm(d, axis=1)
        if np.max(np.abs(np.angle(np.exp(1j * (ang - ang[0]))))) > RADIAL_TOL_RAD:
            return None
        if abs(min(rad[0], rad[-1]) - r_in) > tol or abs(max(rad[0], rad[-1]) - r_out) > tol:
            return None
    return {"panel": panel.name, "centre": centre, "r_in": float(r_in), "r_out": float(r_out),
            "inner": inner, "outer": outer, "sides": lines}


def annular_sectors(base: Pattern) -> list[dict]:
    """Every panel of ``base`` drafted as an annular sector whose outer arc (the hem) is
    stitched to nothing."""
    stitched = {}
    for s in base.stitches:
        for side in (s.a, s.b):
            n = base.panel(side.panel).n_vertices
            stitched.setdefault(side.panel, set()).update(range_indices(side.range, n)[1:-1].tolist())
    out = []
    for panel in base.panels:
        sec = _sector_of(panel)
        if sec is None:
            continue
        hem = set().union(*(run[1:-1].tolist() for run in sec["outer"]))
        if hem & stitched.get(panel.name, set()):
            continue
        out.append(sec)
    return out


def _placed(p: np.ndarray, angle: float, t: np.ndarray) -> np.ndarray:
    """Points p rotated by angle and moved by t (elementwise, as compare.rigid_fit gives them)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.column_stack([c * p[:, 0] - s * p[:, 1] + t[0], s * p[:, 0] + c * p[:, 1] + t[1]])


def _to_sector(p: np.ndarray, sec: dict, r_in: float, along: float, rad: np.ndarray | None = None) -> np.ndarray:
    """Base points p taken to the trued sector: the same angle about the centre, the
    waist's radius r_in, distances from the waist scaled by ``along``."""
    d = np.asarray(p, dtype=float) - sec["centre"]
    if rad is None:
        rad = np.hypot(d[:, 0], d[:, 1])
    a = np.arctan2(d[:, 1], d[:, 0])
    r_new = r_in + (rad - sec["r_in"]) * along
    return np.column_stack([r_new * np.cos(a), r_new * np.sin(a)])


def true_sectors(base: Pattern, outlines: dict[str, np.ndarray],
                 carry: dict[str, np.ndarray] | None = None) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Replaces, in place, the graded outline of every annular-sector panel of ``base``
    (see the module) by the sector with the base's angle, the graded waist's length and the
    graded side seams' mean length. ``carry`` (panel -> points in the base panel's
    coordinates, e.g. its mesh vertices) are taken through the same map, so what lies inside
    the panel stays where the trued outline puts it. Returns the largest move per trued
    panel (mm) and the carried points of the trued panels."""
    moved: dict[str, float] = {}
    carried: dict[str, np.ndarray] = {}
    for sec in annular_sectors(base):
        name = sec["panel"]
        if name not in outlines:
            continue
        o = outlines[name]
        sides = [polyline_length(o[run]) for run in sec["sides"]]
        if abs(sides[0] - sides[1]) > SIDE_MISMATCH_CM:
            continue
        ob = np.asarray(base.panel(name).outline_cm, dtype=float)
        ang = np.arctan2(ob[:, 1] - sec["centre"][1], ob[:, 0] - sec["centre"][0])
        # waist radius whose polyline through the base's angles is as long as the graded
        # waist (the polyline is linear in the radius)
        unit_waist = sum(polyline_length(np.column_stack([np.cos(ang[run]), np.sin(ang[run])]))
                         for run in sec["inner"])
        waist = sum(polyline_length(o[run]) for run in sec["inner"])
        if not (unit_waist > 0 and waist > 0):
            continue
        r_in = waist / unit_waist
        along = 0.5 * (sides[0] + sides[1]) / (sec["r_out"] - sec["r_in"])
        # the arcs exactly on their circles (the files round to 1e-4 cm)
        rad = np.hypot(ob[:, 0] - sec["centre"][0], ob[:, 1] - sec["centre"][1])
        rad[np.concatenate(sec["inner"])] = sec["r_in"]
        rad[np.concatenate(sec["outer"])] = sec["r_out"]
        trued = _to_sector(ob, sec, r_in, along, rad)
        angle, t = rigid_fit(trued, o)
        trued = _placed(trued, angle, t)
        moved[name] = 10.0 * float(np.max(np.linalg.norm(trued - o, axis=1)))
        o[:] = trued
        if carry is not None and name in carry:
            carried[name] = _placed(_to_sector(carry[name], sec, r_in, along), angle, t)
    return moved, carried
