"""The MakeHuman hm08 body model: a base mesh plus blended targets (CC0 data, packed in
``data/hm08_model.npz`` by scripts/pack_body_model.py; licence in data/).

A shape is a few numbers (:class:`ShapeParameters`):

* macro parameters, MakeHuman 1.x scheme: ``gender`` (0 female, 1 male; age 25,
  average muscle and proportions, the three races at 1/3 each are fixed), ``weight``,
  ``height`` and, for women, ``cupsize``, each in [0, 1]. A parameter p is split into
  anchor factors (min = max(0, 1 - 2p), max = max(0, 2p - 1), average = the rest) and the
  target named by a combination of anchors is added with the product of their factors;
* local modifiers, one per measurement (the measure-* targets; inseam is
  measure-upperleg-height), plus neck-scale-horiz and -depth, each in [-1, 1]: v > 0
  adds the ``-incr`` target with weight v, v < 0 the ``-decr`` target with weight -v (or a
  pair (incr, decr) of weights in [0, 1], as a fit may use both).

The body is returned in seamfit's frame: metres, Z up, facing -Y, soles on z = 0, its
bounding box centred on x = y = 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from .io import Body

__all__ = ["LOCAL_MODIFIERS", "ShapeParameters", "body_from_shape", "hm08_faces", "hm08_landmarks",
           "shape_vertices"]

DATA = Path(__file__).resolve().parent / "data" / "hm08_model.npz"
UNIT = 1e-4                         # packed offsets are integers of 0.1 mm
LOCAL_MODIFIERS = ("bust", "underbust", "waist", "hip", "shoulder", "nape_to_waist", "waist_to_hip",
                   "upper_arm", "thigh", "neck", "inseam", "neck_horiz", "neck_depth")
_WEIGHTS = ("minweight", "averageweight", "maxweight")


@dataclass
class ShapeParameters:
    gender: float = 0.0
    weight: float = 0.5
    height: float = 0.5
    cupsize: float = 0.5
    local: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"gender": self.gender, "weight": self.weight, "height": self.height,
                "cupsize": self.cupsize,
                "local": {k: ([float(x) for x in v] if isinstance(v, (tuple, list, np.ndarray)) else float(v))
                          for k, v in self.local.items()}}


class _Model:
    def __init__(self, path: Path):
        with np.load(path) as z:
            self.base = z["base"].astype(np.float64)
            self.triangles = z["triangles"].astype(np.int32)
            self.landmarks = {str(k): int(v) for k, v in zip(z["landmark_names"], z["landmark_vertices"])}
            for ring in ("waist_ring", "underbust_ring", "neck_ring"):
                self.landmarks[ring] = z[ring].astype(int).tolist()
            names = [str(n) for n in z["target_names"]]
            ptr, idx, off = z["target_ptr"], z["target_index"], z["target_offset"]
            self.targets = {n: (idx[ptr[k]:ptr[k + 1]].astype(np.int64),
                                off[ptr[k]:ptr[k + 1]].astype(np.float64) * UNIT)
                            for k, n in enumerate(names)}

    def add(self, V: np.ndarray, name: str, weight: float) -> None:
        if weight != 0.0 and name in self.targets:   # neutral anchors have no target
            i, d = self.targets[name]
            V[i] += weight * d


@lru_cache(maxsize=1)
def _model() -> _Model:
    return _Model(DATA)


def _anchors(p: float) -> dict:
    """MakeHuman's split of a macro value in [0, 1] into min / average / max factors."""
    lo, hi = max(0.0, 1.0 - 2.0 * p), max(0.0, 2.0 * p - 1.0)
    return {"min": lo, "average": 1.0 - lo - hi, "max": hi}


def shape_vertices(shape: ShapeParameters, place: bool = True) -> np.ndarray:
    """Skin vertices (13380, 3) of a shape; with ``place``, grounded and centred."""
    m = _model()
    V = m.base.copy()
    w = _anchors(shape.weight)
    h = _anchors(shape.height)
    c = _anchors(shape.cupsize)
    for g, gw in (("female", 1.0 - shape.gender), ("male", shape.gender)):
        if gw == 0.0:
            continue
        m.add(V, f"race-{g}", gw / 3.0)          # packed as the sum of the three races
        for wa in ("min", "average", "max"):
            m.add(V, f"universal-{g}-{wa}weight", gw * w[wa])
            for ha in ("min", "max"):
                m.add(V, f"height-{g}-{wa}weight-{ha}height", gw * w[wa] * h[ha])
            if g == "female":
                for ca in ("min", "max"):
                    m.add(V, f"breast-{wa}weight-{ca}cup", gw * w[wa] * c[ca])
    for key, v in shape.local.items():
        if key not in LOCAL_MODIFIERS:
            raise KeyError(f"unknown local modifier {key!r}")
        incr, decr = _split(v)
        m.add(V, f"local-{key}-incr", incr)
        m.add(V, f"local-{key}-decr", decr)
    if place:
        lo, hi = V.min(axis=0), V.max(axis=0)
        V -= [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), lo[2]]
    return V


def _split(v) -> tuple[float, float]:
    """A modifier's (incr, decr) weights: from a signed value, or given as a pair (a fit
    may use both targets; the body is linear in each)."""
    if isinstance(v, (tuple, list, np.ndarray)):
        return float(v[0]), float(v[1])
    v = float(v)
    return max(v, 0.0), max(-v, 0.0)


def hm08_faces() -> np.ndarray:
    """The skin's triangles (26756, 3): each quad cut along its shorter diagonal on the base mesh."""
    return _model().triangles


def hm08_landmarks() -> dict:
    """The measuring landmarks of every hm08 body: named vertices (those of
    sample_files/bodies/landmarks.json) and the edge loops ``waist_ring`` (MakeHuman's
    natural waist), ``underbust_ring`` and ``neck_ring``, for ``body_measurements``."""
    return {k: (list(v) if isinstance(v, list) else v) for k, v in _model().landmarks.items()}


def landmarks_of(*bodies) -> dict | None:
    """The hm08 landmarks where every body is of MakeHuman's mesh (its faces), else None."""
    faces = hm08_faces()
    if not all(np.array_equal(np.asarray(b.faces), faces) for b in bodies):
        return None
    return hm08_landmarks()


def body_from_shape(shape: ShapeParameters, name: str = "body") -> Body:
    return Body(shape_vertices(shape), hm08_faces(), name=name)
