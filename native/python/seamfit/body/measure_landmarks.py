"""Measurements taken from the hm08 landmarks and rings (``seamfit.body.hm08_landmarks()``),
as the sample bodies were measured (sample_files/bodies, /data/bodies/README.md):

  underbust      horizontal tape girth at the mean height of the front half of the
                 under-bust ring (the inframammary fold);
  shoulder       straight distance between the shoulder points (biacromial breadth);
  nape_to_waist  taut tape down the back midline (the plane x = x of the cervicale)
                 from the cervicale to the waist level, bridging the small of the back;
  waist_to_hip   waist level minus hip level;
  upper_arm      left arm's tape girth in the plane perpendicular to the shoulder
                 point -> elbow axis, through its midpoint;
  thigh          fullest tape girth of the left leg alone in [crotch - 10 cm, crotch - 1 cm];
  neck           tape girth in the least-squares plane of the neck ring, the section
                 nearest the ring's centre;
  inseam         height of the crotch vertex above the soles.

Each is taken only when its landmarks are given. Tape girth = perimeter of the convex
hull of the section in its plane, as for bust, waist and hip.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import vstack

from ..errors import BodyError
from .io import Body
from .tape import Tape

__all__ = ["landmark_measurements"]


def landmark_measurements(s, body: Body, lm: dict, out: dict, tapes: dict | None) -> None:
    """Add the measurements above to ``out`` (and their tapes to ``tapes``)."""
    from .measure import horizontal_girth_tape, landmark_z, _extremum

    V, n = body.vertices, body.n_vertices
    largest = max(max(np.atleast_1d(v)) for v in lm.values())
    if largest >= n:
        raise BodyError(f"{body.where}: landmark vertex {largest} is out of range ({n} vertices); "
                        "these landmarks are for another mesh")
    lv = out["levels_z_m"]
    found: dict = {}
    if "underbust_ring" in lm:
        ring = np.asarray(lm["underbust_ring"])
        front = ring[V[ring, 1] < np.median(V[ring, 1])]     # the front half: the body faces -Y
        lv["underbust"] = z = float(V[front, 2].mean())
        found["underbust"] = horizontal_girth_tape(s, z)
    if "shoulder_point_L" in lm and "shoulder_point_R" in lm:
        found["shoulder"] = Tape.at_vertices("distance", [lm["shoulder_point_L"], lm["shoulder_point_R"]], n)
    if all(k in lm for k in ("nape_cervicale", "neck_front_base", "waist_front", "waist_back")):
        found["nape_to_waist"] = _back_tape(body, lm, lv["waist"])
    waist_vertices = lm.get("waist_ring") or [lm[k] for k in ("waist_front", "waist_back", "waist_side_L",
                                                             "waist_side_R") if k in lm]
    if waist_vertices:
        a, b, t, _ = s.cut(lv["hip"])
        ids = s.torso_ids(lv["hip"])
        w = np.asarray(waist_vertices)
        found["waist_to_hip"] = Tape.on_edges("vertical", np.r_[w, a[ids]], np.r_[w, b[ids]],
                                              np.r_[np.zeros(len(w)), t[ids]], n, split=len(w))
    if "shoulder_point_L" in lm and "elbow_L" in lm:
        S, E = V[lm["shoulder_point_L"]], V[lm["elbow_L"]]
        found["upper_arm"] = _plane_girth_tape(body, E - S, 0.5 * (S + E), "upper arm")
    if "knee_L" in lm:
        crotch = landmark_z(body, lm, "crotch")
        knee = V[lm["knee_L"], :2]
        lv["thigh"], _ = _extremum(s, crotch - 0.10, crotch - 0.01, largest=True,
                                   girth=lambda z: _leg_girth(s, z, knee)[0])
        found["thigh"] = _leg_girth(s, lv["thigh"], knee)[1]
    if "neck_ring" in lm:
        ring = V[np.asarray(lm["neck_ring"])]
        c = ring.mean(axis=0)
        normal = np.linalg.svd(ring - c)[2][2]
        found["neck"] = _plane_girth_tape(body, normal if normal[2] > 0 else -normal, c, "neck")
    if "crotch" in lm:
        found["inseam"] = Tape.at_vertices("vertical", [lm["crotch"], int(np.argmin(V[:, 2]))], n, split=1)
    for key, tape in found.items():
        out[key] = tape.length(V)
    if tapes is not None:
        tapes.update(found)


def _frame(normal) -> np.ndarray:
    """A rotation (rows u, v, n) that turns ``normal`` into Z."""
    nrm = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(nrm, [0.0, 1.0, 0.0] if abs(nrm[1]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(nrm, u), nrm])


def _plane_slicer(body: Body, R: np.ndarray):
    """A slicer of the body turned by R: its levels are heights along R's last row."""
    from .measure import _Slicer
    return _Slicer(Body(body.vertices @ R.T, body.faces, name=body.name))


def _plane_girth_tape(body: Body, normal, centre, what: str) -> Tape:
    """Tape girth of the section, in the plane through ``centre`` with ``normal``,
    whose loop's centre is nearest ``centre``."""
    R = _frame(normal)
    ps = _plane_slicer(body, R)
    c = R @ centre
    loops = ps.loop_ids(float(c[2]))
    if not loops:
        raise BodyError(f"{body.where}: no {what} section found")
    a, b, t, P = ps.cut(float(c[2]))
    ids = min(loops, key=lambda i: np.linalg.norm(P[i].mean(axis=0) - c[:2]))
    return Tape.on_edges("girth", a[ids], b[ids], t[ids], body.n_vertices, basis=R[:2])


def _leg_girth(s, z: float, knee_xy) -> tuple[float, Tape | None]:
    """Tape girth of the left leg's loop at z (the loop, not spanning the midline, whose
    centre is nearest the left knee), and its tape."""
    a, b, t, P = s.cut(z)
    loops = [i for segs, i in zip(s.loops(z), s.loop_ids(z)) if not s.spans_midline(segs)]
    if not loops:
        return float("nan"), None
    ids = min(loops, key=lambda i: np.linalg.norm(P[i].mean(axis=0) - knee_xy))
    tape = Tape.on_edges("girth", a[ids], b[ids], t[ids], len(s.V), basis=np.eye(3)[:2])
    return tape.length(s.V) / 100.0, tape


def _back_tape(body: Body, lm: dict, waist_z: float) -> Tape:
    """Points of the back midline profile between the waist level and the cervicale."""
    V = body.vertices
    top = lm["nape_cervicale"]
    ps = _plane_slicer(body, np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 0]]))   # section coordinates (y, z)
    x0 = float(V[top, 0])
    a, b, t, P = ps.cut(x0)
    if len(P) == 0:
        raise BodyError(f"{body.where}: no midline section for the nape to waist length")
    # The trunk's centre line, from the waist's centre to the neck base's: back points lie behind it.
    (yw, zw) = 0.5 * (V[lm["waist_front"], 1:] + V[lm["waist_back"], 1:])
    (yn, zn) = 0.5 * (V[top, 1:] + V[lm["neck_front_base"], 1:])
    centre_y = yw + (P[:, 1] - zw) * (yn - yw) / (zn - zw)
    back = P[:, 0] > centre_y
    keep = np.flatnonzero(back & (P[:, 1] > waist_z) & (P[:, 1] < V[top, 2]))
    # Where the back profile crosses the waist level: the segment crossing it farthest back.
    s0, s1 = ps.segments(x0)
    cross = (back[s0] & back[s1]) & ((P[s0, 1] - waist_z) * (P[s1, 1] - waist_z) <= 0) & (P[s0, 1] != P[s1, 1])
    if not keep.size or not cross.any():
        raise BodyError(f"{body.where}: the back midline does not reach from the nape to the waist")
    k = np.flatnonzero(cross)[np.argmax(P[s0[cross], 0] + P[s1[cross], 0])]
    i, j = s0[k], s1[k]
    f = (waist_z - P[i, 1]) / (P[j, 1] - P[i, 1])
    pts = Tape.on_edges("back", a[keep], b[keep], t[keep], body.n_vertices)
    ends = Tape.on_edges("back", [a[i], a[j], top], [b[i], b[j], top], [t[i], t[j], 0.0], body.n_vertices)
    bottom = (1.0 - f) * ends.W[0] + f * ends.W[1]
    return Tape("back", vstack([pts.W, bottom, ends.W[2]]).tocsr())
