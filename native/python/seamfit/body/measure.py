"""Body measurements: height and horizontal tape girths (bust, waist, hip), in cm.

A tape girth at height z is the perimeter of the 2-D convex hull of the torso's
cross-section at z (a tape bridges the cleavage and the small of the back).
The torso's section is the loop (or loops) of the plane cut that encloses the
body's centre axis (else those spanning the midline x = axis); arm and hand loops
are left out. The centre axis is the xy centre of the bounding box of the
vertices between 0.45 and 0.75 of the height.

Levels. With ``landmarks`` (vertex indices as in sample_files/bodies/landmarks.json):
  waist  = mean height of the waist_front/back/side_L/side_R vertices (natural waist);
  bust   = fullest torso girth in [bust points - 4 cm, armpit - 1 cm];
  hip    = fullest torso girth in [crotch + 1 cm, waist - 5 cm].
Without landmarks (any Z-up mesh), with H the height and z measured from the soles:
  crotch = lowest level in [0.35 H, 0.65 H] where one loop spans the midline (the
           legs have joined);
  armpit = lowest level above 0.6 H where the arms' loops have merged with the torso's;
  bust   = fullest torso girth in [0.68 H, armpit - 1 cm];
  waist  = smallest torso girth in [crotch + 0.1 H, 0.68 H] (the minimum girth, which
           on these bodies lies a few cm above the natural waist);
  hip    = fullest torso girth in [crotch + 1 cm, waist - 5 cm].
The armpit is where the cross-section stops having separate arm loops (found by
bisection to 1 mm).
"""
from __future__ import annotations

import copy
import hashlib
import json
import threading
from collections import OrderedDict
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import BodyError
from .io import Body
from .tape import Tape

__all__ = ["MEASUREMENTS", "body_measurements", "cross_section_girth", "cross_section_loops"]

_COARSE = 0.005  # level scan step (m); extrema are then refined to 1 mm


def encloses(segs, x: float, y: float) -> bool:
    """Whether the loop of xy segments (k, 2, 2) goes around the point (x, y): ray-crossing
    parity along +x."""
    p, q = segs[:, 0], segs[:, 1]
    straddle = (p[:, 1] > y) != (q[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = p[:, 0] + (y - p[:, 1]) * (q[:, 0] - p[:, 0]) / (q[:, 1] - p[:, 1])
    return int(np.count_nonzero(straddle & (xc > x))) % 2 == 1


class _Slicer:
    def __init__(self, body: Body):
        self.V = body.vertices
        self.F = body.faces.astype(np.int64)
        z = self.V[:, 2][self.F]
        self.zmin, self.zmax = z.min(axis=1), z.max(axis=1)
        order = np.argsort(self.zmin)
        self.order, self.sorted_zmin = order, self.zmin[order]
        self.sorted_zmax = self.zmax[order]
        self.z0, self.z1 = float(self.V[:, 2].min()), float(self.V[:, 2].max())
        self.H = self.z1 - self.z0
        band = (self.V[:, 2] > self.z0 + 0.45 * self.H) & (self.V[:, 2] < self.z0 + 0.75 * self.H)
        pts = self.V[band] if band.any() else self.V
        self.axis = 0.5 * (pts[:, :2].min(axis=0) + pts[:, :2].max(axis=0))
        self._cache: dict = {}
        self._cuts: dict = {}
        self._loop_ids: dict = {}
        self._segments: dict = {}

    def cut(self, z: float):
        """Where the plane at height z crosses the mesh's edges: vertex ids a, b and t
        (the point is V[a] + t (V[b] - V[a])), and the points' xy; on a body of the same
        topology the same (a, b, t) give the corresponding curve."""
        self.loops(z)
        key = round(z, 7)
        return self._cuts.get(key, (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2))))

    def loops(self, z: float) -> list[np.ndarray]:
        """Cross-section at height z: one (k, 2, 2) array of xy segments per loop."""
        key = round(z, 7)
        if key in self._cache:
            return self._cache[key]
        n = np.searchsorted(self.sorted_zmin, z, side="right")
        cand = self.order[:n][self.sorted_zmax[:n] > z]
        if cand.size == 0:
            self._cache[key] = []
            return []
        F = self.F[cand]
        zz = self.V[F, 2]
        above = zz > z  # a vertex exactly at z counts as below: no degenerate cuts
        ends = []
        for e0, e1 in ((0, 1), (1, 2), (2, 0)):
            cut = above[:, e0] != above[:, e1]
            ends.append((cut, F[:, e0], F[:, e1]))
        # Each cut triangle has exactly two cut edges: its segment joins them.
        cut_mask = np.stack([c for c, _, _ in ends], axis=1)
        keep = cut_mask.sum(axis=1) == 2
        edge_keys = []
        for c, a, b in ends:
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            edge_keys.append(np.where(c, lo * len(self.V) + hi, -1))
        ek = np.stack(edge_keys, axis=1)[keep]
        cm = cut_mask[keep]
        first = np.where(cm[:, 0], ek[:, 0], ek[:, 1])
        second = np.where(cm[:, 2], ek[:, 2], ek[:, 1])
        uniq, inv = np.unique(np.concatenate([first, second]), return_inverse=True)
        a, b = uniq // len(self.V), uniq % len(self.V)
        za, zb = self.V[a, 2], self.V[b, 2]
        t = (z - za) / (zb - za)
        P = self.V[a, :2] + t[:, None] * (self.V[b, :2] - self.V[a, :2])
        self._cuts[key] = (a, b, t, P)
        m = len(first)
        s0, s1 = inv[:m], inv[m:]
        ncomp, lab = connected_components(coo_matrix((np.ones(m), (s0, s1)), shape=(len(uniq), len(uniq))),
                                          directed=False)
        seg_lab = lab[s0]
        out = []
        for c in range(ncomp):
            sel = seg_lab == c
            out.append(np.stack([P[s0[sel]], P[s1[sel]]], axis=1))
        self._cache[key] = out
        self._loop_ids[key] = [np.flatnonzero(lab == c) for c in range(ncomp)]
        self._segments[key] = (s0, s1)
        return out

    def segments(self, z: float) -> tuple[np.ndarray, np.ndarray]:
        """The section's segments at z as pairs of indices into ``cut(z)``."""
        self.loops(z)
        return self._segments.get(round(z, 7), (np.zeros(0, np.int64), np.zeros(0, np.int64)))

    def loop_ids(self, z: float) -> list[np.ndarray]:
        """Per loop of the section at z, its points as indices into ``cut(z)``."""
        self.loops(z)
        return self._loop_ids.get(round(z, 7), [])

    def torso_ids(self, z: float) -> np.ndarray:
        """Indices into ``cut(z)`` of the points of the loops ``torso(z)`` keeps."""
        keep, _ = self.torso(z)
        kept = {id(s) for s in keep}
        ids = [i for segs, i in zip(self.loops(z), self.loop_ids(z)) if id(segs) in kept]
        return np.concatenate(ids) if ids else np.zeros(0, np.int64)

    def torso(self, z: float):
        """Loops of the section at z that enclose the centre axis (ray-crossing parity)."""
        loops = self.loops(z)
        keep = [segs for segs in loops if encloses(segs, *self.axis)]
        if not keep:  # a torso whose section misses the axis point still spans the midline
            keep = [segs for segs in loops if self.spans_midline(segs)]
        return keep, len(loops)

    def spans_midline(self, segs) -> bool:
        x = segs[:, :, 0]
        return bool(x.min() < self.axis[0] < x.max())

    def girth(self, z: float) -> float:
        keep, _ = self.torso(z)
        if not keep:
            return float("nan")
        return _hull_perimeter(np.concatenate([s.reshape(-1, 2) for s in keep]))


def _hull_perimeter(pts: np.ndarray) -> float:
    """Perimeter of the 2-D convex hull (Qhull; a monotone chain where Qhull refuses
    degenerate input such as collinear points)."""
    if len(pts) >= 3:
        from scipy.spatial import ConvexHull, QhullError   # here: importing seamfit.body stays light
        try:
            h = ConvexHull(pts)
        except (QhullError, ValueError):
            pass
        else:
            p = pts[h.vertices]
            return float(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1).sum())
    pts = np.unique(np.round(pts, 12), axis=0)
    if len(pts) < 3:
        return float(2 * np.linalg.norm(pts[-1] - pts[0])) if len(pts) == 2 else 0.0
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def half(points):
        h = []
        for p in points:
            while len(h) >= 2 and ((h[-1][0] - h[-2][0]) * (p[1] - h[-2][1]) -
                                   (h[-1][1] - h[-2][1]) * (p[0] - h[-2][0])) <= 0:
                h.pop()
            h.append(p)
        return h

    lower, upper = half(pts), half(pts[::-1])
    hull = np.array(lower[:-1] + upper[:-1])
    return float(np.linalg.norm(np.diff(np.vstack([hull, hull[:1]]), axis=0), axis=1).sum())


def cross_section_loops(body: Body, z: float) -> list[np.ndarray]:
    """The section of ``body`` at height z as loops of xy segments ((k, 2, 2) each)."""
    return _Slicer(body).loops(z)


def cross_section_girth(body: Body, z: float) -> float:
    """Tape girth (m) of the torso at height z: convex-hull perimeter of the loops
    enclosing the body's centre axis; NaN if none does (e.g. between the legs)."""
    return _Slicer(body).girth(z)


def _extremum(s: _Slicer, lo: float, hi: float, largest: bool, girth=None) -> tuple[float, float]:
    """Level in [lo, hi] with the largest (or smallest) torso girth (or ``girth(z)``):
    a 5 mm scan, then 1 mm around the best level."""
    girth = s.girth if girth is None else girth
    if hi < lo:
        raise BodyError(f"{_where(s)}: empty measuring band [{lo:.3f}, {hi:.3f}] m")
    zs = np.arange(lo, hi + 1e-9, _COARSE)
    g = np.array([girth(z) for z in zs])
    if np.all(np.isnan(g)):
        raise BodyError(f"{_where(s)}: no torso cross-section in [{lo:.3f}, {hi:.3f}] m")
    k = int(np.nanargmax(g) if largest else np.nanargmin(g))
    fine = np.clip(np.arange(zs[k] - _COARSE, zs[k] + _COARSE + 1e-9, 0.001), lo, hi)
    gf = np.array([girth(z) for z in fine])
    k2 = int(np.nanargmax(gf) if largest else np.nanargmin(gf))
    return float(fine[k2]), float(gf[k2])


def _where(s: _Slicer) -> str:
    return getattr(s, "where", "body")


def _first_true(pred, lo: float, hi: float, step: float = _COARSE) -> float | None:
    """Lowest z in [lo, hi] where pred holds (scan, then bisection to 1 mm)."""
    prev = lo
    for z in np.arange(lo, hi + 1e-9, step):
        if pred(z):
            if z == lo:
                return float(z)
            a, b = prev, float(z)
            while b - a > 0.001:
                m = 0.5 * (a + b)
                a, b = (a, m) if pred(m) else (m, b)
            return b
        prev = float(z)
    return None


def _load_landmarks(landmarks) -> dict:
    if isinstance(landmarks, (str, Path)):
        try:
            landmarks = json.loads(Path(landmarks).read_text())
        except (OSError, ValueError) as exc:
            raise BodyError(f"{landmarks}: cannot read landmarks: {exc}") from None
    if isinstance(landmarks, dict) and "vertex_indices" in landmarks:
        landmarks = landmarks["vertex_indices"]
    # a named vertex, or a ring of vertices (waist_ring, underbust_ring, neck_ring)
    return {str(k): ([int(i) for i in v] if isinstance(v, (list, tuple, np.ndarray)) else int(v))
            for k, v in dict(landmarks).items()}


MEASUREMENTS = ("height", "bust", "underbust", "waist", "hip", "shoulder", "nape_to_waist",
                "waist_to_hip", "upper_arm", "thigh", "neck", "inseam")


def body_measurements(body: Body, landmarks=None, tapes: bool = False) -> dict:
    """Height and tape girths (bust, waist, hip) in cm, plus the levels used
    (``levels_z_m``) and the ``method`` ("landmarks" or "heuristic").

    With the hm08 landmarks (``seamfit.body.hm08_landmarks()``: named vertices and the
    waist, under-bust and neck rings) also underbust, shoulder, nape_to_waist,
    waist_to_hip, upper_arm, thigh, neck and inseam (measure_landmarks.py), each taken where
    its landmarks are given. With ``tapes``, ``result["tapes"]`` holds a
    :class:`seamfit.body.tape.Tape` per measurement, to re-take it on a reshaped body.

    Each call returns a dict of its own; without ``tapes`` it may be a copy of one measured
    earlier on a mesh with the same vertices and faces (see ``_remembered``)."""
    if tapes:
        return _measure(body, landmarks, tapes=True)
    lm = _load_landmarks(landmarks) if landmarks is not None else None
    return _remembered(body, lm)


# A grading measures the same two bodies several times (level scaling, the ease, the
# scaling baseline), at about 0.1 s each: the last few results are kept, keyed by the
# mesh's content and the landmarks, so a body changed in place is measured afresh.
_MEMO_SIZE = 8
_memo: OrderedDict = OrderedDict()
_memo_lock = threading.Lock()
_measuring: dict = {}       # key -> Event, set when that measurement ends


def _remembered(body: Body, lm: dict | None) -> dict:
    h = hashlib.blake2b(digest_size=20)
    for a in (body.vertices, body.faces):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.data)
    h.update(json.dumps(lm, sort_keys=True).encode())
    key = h.hexdigest()
    while True:
        with _memo_lock:
            found = _memo.get(key)
            if found is not None:
                _memo.move_to_end(key)
                return copy.deepcopy(found)
            busy = _measuring.get(key)
            if busy is None:            # nobody measures it: this thread does
                busy = _measuring[key] = threading.Event()
                break
        # Another thread (seamfit.preload's, measuring ahead) has it in hand: wait for it,
        # then read the memo; if that measurement failed, measure here.
        busy.wait()
    try:
        found = _measure(body, lm, tapes=False)
        with _memo_lock:
            _memo[key] = found
            while len(_memo) > _MEMO_SIZE:
                _memo.popitem(last=False)
    finally:
        with _memo_lock:
            _measuring.pop(key, None)
        busy.set()
    return copy.deepcopy(found)


def _measure(body: Body, landmarks, tapes: bool) -> dict:
    s = _Slicer(body)
    s.where = body.where
    z0, H = s.z0, s.H
    if not (0.3 < H < 3.0):
        raise BodyError(f"{body.where}: height {H:.4g} is not a body height in metres")
    lm = _load_landmarks(landmarks) if landmarks is not None else None

    def arms_merged(z):
        loops = s.loops(z)
        return len(loops) <= 1

    if lm is not None:
        crotch = landmark_z(body, lm, "crotch")
        if "waist_ring" in lm:     # MakeHuman's natural waist: the mean height of its ring
            waist_z = landmark_z(body, lm, "waist_ring")
        else:
            waist_z = landmark_z(body, lm, "waist_front", "waist_back", "waist_side_L", "waist_side_R")
        bust_lo = landmark_z(body, lm, "bust_point_L", "bust_point_R") - 0.04
        method = "landmarks"
    else:
        crotch = _first_true(lambda z: any(s.spans_midline(g) for g in s.loops(z)), z0 + 0.35 * H, z0 + 0.65 * H)
        if crotch is None:
            raise BodyError(f"{body.where}: no crotch found (no torso section between 0.35 and 0.65 of the height)")
        bust_lo = z0 + 0.68 * H
        method = "heuristic"
    armpit = _first_true(arms_merged, max(bust_lo, z0 + 0.6 * H), z0 + 0.9 * H)
    if armpit is None:
        raise BodyError(f"{body.where}: no armpit level found (the arms never join the torso)")
    if lm is None:
        waist_z, waist = _extremum(s, crotch + 0.1 * H, z0 + 0.68 * H, largest=False)
    else:
        waist = s.girth(waist_z)
    bust_z, bust = _extremum(s, bust_lo, armpit - 0.01, largest=True)
    hip_z, hip = _extremum(s, crotch + 0.01, waist_z - 0.05, largest=True)
    out = {
        "height": 100.0 * H,
        "bust": 100.0 * bust,
        "waist": 100.0 * waist,
        "hip": 100.0 * hip,
        "levels_z_m": {"crotch": crotch, "hip": hip_z, "waist": waist_z, "bust": bust_z, "armpit": armpit},
        "method": method,
    }
    found = {}
    if tapes:
        n = body.n_vertices
        found["height"] = Tape.at_vertices("vertical", [int(np.argmax(body.vertices[:, 2])),
                                                        int(np.argmin(body.vertices[:, 2]))], n, split=1)
        for key, z in (("bust", bust_z), ("waist", waist_z), ("hip", hip_z)):
            found[key] = horizontal_girth_tape(s, z)
    if lm is not None:
        from .measure_landmarks import landmark_measurements
        landmark_measurements(s, body, lm, out, found if tapes else None)
    if tapes:
        out["tapes"] = found
    return out


def horizontal_girth_tape(s: _Slicer, z: float) -> Tape:
    """The torso's tape girth at height z as a :class:`Tape`."""
    a, b, t, _ = s.cut(z)
    ids = s.torso_ids(z)
    return Tape.on_edges("girth", a[ids], b[ids], t[ids], len(s.V), basis=_XY)


_XY = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def landmark_z(body: Body, lm: dict, *names) -> float:
    """Mean height of the named landmark vertices (a ring counts all its vertices)."""
    try:
        idx = np.concatenate([np.atleast_1d(lm[n]) for n in names])
        return float(body.vertices[idx, 2].mean())
    except KeyError as exc:
        raise BodyError(f"{body.where}: landmark {exc.args[0]!r} missing") from None
    except IndexError:
        raise BodyError(f"{body.where}: a landmark index is out of range "
                        f"({body.n_vertices} vertices)") from None
