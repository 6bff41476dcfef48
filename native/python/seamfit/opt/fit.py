"""Fit measures a pattern maker reads: ease = garment girth minus body girth.

Girths are tape girths, as the bodies are measured: the perimeter of the convex hull
of the horizontal cross-section (a tape bridges hollows and folds). The body's tape goes
around the torso under the arms, so the garment's tape does too: where the body's section
has arm loops besides the torso's, only the cloth nearest the torso counts, not the hull
around both sleeves. A garment encloses a level only where its section goes around the
torso there: a bodice whose back ends above the waist has no waist girth.
"""
from __future__ import annotations

import numpy as np

from .. import preload
from ..body.measure import _hull_perimeter, _Slicer, body_measurements
from ..body.shape_model import landmarks_of

# scipy.spatial (hulls, nearest points) is imported where it is used: a grading imports
# this module at its start, and the level scaling, right after the body fields, is the
# first to need it, so it loads on seamfit.preload's thread while the fields are built.
preload.want("scipy.spatial", first=True)

# A garment goes around the torso at a level when no torso point lies farther than this
# (m) outside its section's hull: cloth rests a few mm out, a missing panel leaves
# centimetres of body uncovered.
ENCLOSE_TOL_M = 0.01
# A graded garment has lost the fit its base pattern gave at a tape level when it keeps
# under half the base garment's ease there and at least this much less (cm): a tape's
# reading moves by a few millimetres with the drape, a centimetre is felt when worn.
EASE_LOSS_CM = 1.0


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


def hull(points):
    """2-D convex hull, or None for degenerate input."""
    from scipy.spatial import ConvexHull, QhullError
    try:
        return ConvexHull(points)
    except (QhullError, ValueError):
        return None


def torso_cloth(slicer: _Slicer, z: float, body_pts: np.ndarray, garment_pts: np.ndarray):
    """Where the body's section at z has arm loops besides the torso's: (torso ids into
    ``body_pts``, the garment points nearest the torso, their hull). None where the
    section is one loop or the split leaves too little."""
    if len(body_pts) < 3 or len(garment_pts) < 3:
        return None
    ids = slicer.torso_ids(z)
    if not 3 <= len(ids) < len(body_pts):
        return None
    # The torso is the section's largest piece (arms are smaller); at the crotch the loop
    # round the axis can be a sliver between the legs, and the cloth nearest it no girth.
    torso_girth = _hull_perimeter(body_pts[ids])
    if any(_hull_perimeter(body_pts[other]) > torso_girth
           for other in slicer.loop_ids(z) if not np.isin(other, ids).any()):
        return None
    on_torso = np.zeros(len(body_pts), dtype=bool)
    on_torso[ids] = True
    from scipy.spatial import cKDTree
    _, nearest = cKDTree(body_pts).query(garment_pts)
    kept = garment_pts[on_torso[nearest]]
    h = hull(kept) if len(kept) >= 3 else None
    return None if h is None else (ids, kept, h)


def outside_by(hull, points: np.ndarray) -> np.ndarray:
    """Per point, how far (m) it lies outside the 2-D hull along the farthest facet's
    normal: <= 0 inside, the distance for a point beyond one edge, a lower bound past a
    corner."""
    eq = hull.equations
    return (points @ eq[:, :2].T + eq[:, 2]).max(axis=1)


def goes_around(garment_hull, body_pts: np.ndarray) -> bool:
    """Whether the garment's section (its hull) goes around the body's section points."""
    return bool(outside_by(garment_hull, body_pts).max() <= ENCLOSE_TOL_M)


def garment_tape(slicer: _Slicer, x: np.ndarray, triangles: np.ndarray, z: float) -> tuple[float, float]:
    """(garment tape girth, body tape girth) in m at height z, both around the torso;
    NaN where the garment does not go around the torso there."""
    garment_pts = mesh_cross_section(x, triangles, z)
    body_pts = slicer.cut(z)[3]
    if len(garment_pts) < 3 or len(body_pts) < 3:
        return float("nan"), float("nan")
    torso = torso_cloth(slicer, z, body_pts, garment_pts)
    if torso is not None:
        ids, _, hg = torso
        body_pts = body_pts[ids]
    else:
        hg = hull(garment_pts)
        if hg is None:
            return float("nan"), float("nan")
    if not goes_around(hg, body_pts):
        return float("nan"), float("nan")
    return _hull_perimeter(hg.points[hg.vertices]), slicer.girth(z)


def ease_levels(body) -> dict:
    """The heights (m) ease is taken at: the body's measuring levels (bust, waist, hip), the
    bust at the bust points' height on a body of MakeHuman's mesh. Its bust tape is the
    fullest girth below the armpits, which on a small bust is the chest under the arms
    (size 02 and pear: 3.2-3.5 cm above the bust points), where a sleeveless bodice's
    section is open at the armholes and its hull no tape of the garment; drafting takes the
    bust's ease over the bust points."""
    levels = dict(body_measurements(body)["levels_z_m"])
    lm = landmarks_of(body)
    if lm is not None:
        v = np.asarray(body.vertices, dtype=float)
        levels["bust"] = float(v[[lm["bust_point_L"], lm["bust_point_R"]], 2].mean())
    return levels


def ease_report(body, x: np.ndarray, triangles: np.ndarray, levels: dict | None = None) -> dict:
    """Ease (cm) at bust, waist and hip: garment girth minus body girth at the body's
    ``ease_levels``, both around the torso. None where the garment does not go around the
    torso at that level."""
    if levels is None:
        levels = ease_levels(body)
    slicer = _Slicer(body)
    out = {}
    for name in ("bust", "waist", "hip"):
        z = levels.get(name)
        if z is None:
            out[name] = None
            continue
        gg, bg = garment_tape(slicer, x, triangles, z)
        out[name] = None if not (np.isfinite(gg) and np.isfinite(bg)) else round(100.0 * (gg - bg), 2)
    return out


def tighter_levels(base: dict, result: dict) -> list[str]:
    """The tape levels (bust, waist, hip) where the graded garment (``result``, ease in cm on
    the target body) keeps under half the base garment's ease on the base body (``base``)
    and at least EASE_LOSS_CM less: tighter there than the base pattern on its own body,
    which wants a pattern maker's look before cutting (of the shared drafts themselves, 2 in
    48 come out so). A garment that came out looser is not flagged."""
    out = []
    for name in ("bust", "waist", "hip"):
        e0, e1 = (base or {}).get(name), (result or {}).get(name)
        if e0 is not None and e1 is not None and e0 - e1 >= EASE_LOSS_CM and e1 < 0.5 * e0:
            out.append(name)
    return out


def ease_losses(base: dict, result: dict) -> list[str]:
    """One line for the user per level of ``tighter_levels``, with both eases."""
    return [f"the graded garment is tighter at the {name} than the base pattern on its body: "
            f"{result[name]:+.1f} cm of ease where the base garment has {base[name]:+.1f} cm"
            for name in tighter_levels(base, result)]
