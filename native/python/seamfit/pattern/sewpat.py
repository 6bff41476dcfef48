"""Read and write the ``sewpat-1`` JSON format losslessly.

Known keys become typed fields; every other key is kept in the object's ``extra``
and written back unchanged, so read -> write -> read gives equal data.
Derived keys (``n_vertices``, ``area_cm2``) are recomputed on write.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_text
from .json_file import read_json
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide

FORMAT = "sewpat-1"

_PATTERN_KEYS = {"format", "garment_type", "garment_id", "body_id", "fabric", "panels", "stitches"}
_PANEL_KEYS = {"name", "outline_cm", "orientation", "nodes", "corners", "landmarks", "edges",
               "placement", "n_vertices", "area_cm2"}
_EDGE_KEYS = {"id", "start", "end", "kind", "p0", "p1", "ctrl", "arc", "length_cm", "label"}
_PLACEMENT_KEYS = {"kind", "rotation_matrix", "translation_m", "side"}
_STITCH_KEYS = {"kind", "a", "b", "orientation", "gathered", "length_a_cm", "length_b_cm"}
_SIDE_KEYS = {"panel", "range", "edge", "landmarks"}


def _rest(d: dict, known: set) -> dict:
    return {k: v for k, v in d.items() if k not in known}


def _need(d: dict, key: str, where: str) -> Any:
    if key not in d:
        raise PatternError(f"{where}: missing key {key!r}")
    return d[key]


def _obj(v, where: str) -> dict:
    if not isinstance(v, dict):
        raise PatternError(f"{where}: expected a JSON object, got {_kind(v)}")
    return v


def _list(v, where: str, what: str) -> list:
    if not isinstance(v, list):
        raise PatternError(f"{where}: {what} must be a list, got {_kind(v)}")
    return v


def _kind(v) -> str:
    """A JSON value's type as a user knows it, without echoing a huge value."""
    return {dict: "an object", list: "a list", str: "a string", bool: "true/false", int: "a number",
            float: "a number", type(None): "null"}.get(type(v), type(v).__name__)


def _int(v, where: str) -> int:
    # JSON numbers only: 2.0 is 2, but 2.5, "2", true and null are not indices
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (isinstance(v, float) and not v.is_integer()):
        raise PatternError(f"{where}: expected a whole number, got {_kind(v)} {_short(v)}".rstrip())
    return int(v)


def _short(v) -> str:
    if v is None or isinstance(v, bool):
        return ""                                # _kind said it all
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def _name(v, where: str) -> str:
    if not isinstance(v, str) or not v:
        raise PatternError(f"{where}: a name must be a non-empty string, got {_kind(v)} {_short(v)}".rstrip())
    return v


def _pair(v, where: str) -> tuple[float, float]:
    if not (isinstance(v, list) and len(v) == 2 and all(_is_num(c) for c in v)):
        raise PatternError(f"{where}: expected a 2D point [u, v], got {_short(v)}")
    return (float(v[0]), float(v[1]))


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _points(v, where: str, what: str, dim: int) -> np.ndarray:
    """A list of [x, y(, z)] numbers as a float array (huge integers become inf, which the
    validator reports as non-finite)."""
    _list(v, where, what)
    for k, q in enumerate(v):
        if not (isinstance(q, list) and len(q) == dim and all(_is_num(c) for c in q)):
            raise PatternError(f"{where}: {what} item {k} must be {dim} numbers, got {_short(q)}")
    with np.errstate(over="ignore"):
        try:
            return np.asarray(v, dtype=float).reshape(len(v), dim)
        except OverflowError:
            return np.array([[_float(c) for c in q] for q in v]).reshape(len(v), dim)


def _float(c) -> float:
    try:
        return float(c)
    except OverflowError:                       # an integer beyond the float range
        return float("inf") if c > 0 else float("-inf")


def _edge_from(d: dict, where: str) -> Edge:
    _obj(d, where)
    ctrl = d.get("ctrl", [])
    return Edge(
        id=_int(_need(d, "id", where), where + ".id"), start=_int(_need(d, "start", where), where + ".start"),
        end=_int(_need(d, "end", where), where + ".end"),
        kind=_name(_need(d, "kind", where), where + ".kind"),
        p0=_pair(_need(d, "p0", where), where + ".p0"), p1=_pair(_need(d, "p1", where), where + ".p1"),
        ctrl=[_pair(c, where + ".ctrl") for c in _list(ctrl, where, "ctrl")] if "ctrl" in d else [],
        arc=d.get("arc"), length_cm=d.get("length_cm"), label=d.get("label"),
        extra={**_rest(d, _EDGE_KEYS), **({"_has_ctrl": True} if "ctrl" in d else {})},
    )


def _placement_from(d: dict, where: str) -> Placement:
    _obj(d, where)
    rot = _points(_need(d, "rotation_matrix", where), where, "rotation_matrix", 3)
    tr = _list(_need(d, "translation_m", where), where, "translation_m")
    if rot.shape != (3, 3) or len(tr) != 3 or not all(_is_num(c) for c in tr):
        raise PatternError(f"{where}: rotation_matrix must be 3x3 and translation_m a 3-vector")
    return Placement(kind=str(d.get("kind", "hint")), rotation=rot, translation_m=np.array([_float(c) for c in tr]),
                     side=d.get("side"), extra=_rest(d, _PLACEMENT_KEYS))


def _panel_from(d: dict, where: str) -> Panel:
    _obj(d, where)
    name = _name(_need(d, "name", where), where + ".name")
    where = f"{where} ({name!r})"
    outline = _points(_need(d, "outline_cm", where), where, "outline_cm", 2)
    if len(outline) < 3:
        raise PatternError(f"{where}: outline_cm must be a list of at least 3 [u, v] points")
    landmarks = _obj(d.get("landmarks", {}), where + ".landmarks")
    return Panel(
        name=name, outline_cm=outline, orientation=str(d.get("orientation", "ccw")),
        nodes=[_int(i, where + ".nodes") for i in _list(d.get("nodes", []), where, "nodes")],
        corners=[_int(i, where + ".corners") for i in _list(d.get("corners", []), where, "corners")],
        landmarks={str(k): _int(v, f"{where} landmark {k!r}") for k, v in landmarks.items()},
        edges=[_edge_from(e, f"{where} edge {k}") for k, e in enumerate(_list(d.get("edges", []), where, "edges"))],
        placement=_placement_from(_need(d, "placement", where), where + " placement"),
        extra=_rest(d, _PANEL_KEYS),
    )


def _side_from(d: dict, where: str) -> StitchSide:
    _obj(d, where)
    r = _list(_need(d, "range", where), where, "range")
    if len(r) != 2:
        raise PatternError(f"{where}: range must be two outline indices [i0, i1], got {_short(r)}")
    return StitchSide(panel=_name(_need(d, "panel", where), where + ".panel"),
                      range=(_int(r[0], where + ".range"), _int(r[1], where + ".range")),
                      edge=d.get("edge"), landmarks=d.get("landmarks"), extra=_rest(d, _SIDE_KEYS))


def pattern_from_dict(d: dict, source: str = "<dict>") -> Pattern:
    from ..limits import OUTLINE_VERTICES, PANELS
    _obj(d, source)
    if d.get("format") != FORMAT:
        raise PatternError(f"{source}: not a {FORMAT} pattern (format = {d.get('format')!r})")
    raw_panels = _list(_need(d, "panels", source), source, "panels")
    PANELS.check(len(raw_panels), source, error=PatternError)
    OUTLINE_VERTICES.check(sum(len(p["outline_cm"]) for p in raw_panels
                               if isinstance(p, dict) and isinstance(p.get("outline_cm"), list)), source,
                           error=PatternError)
    panels = [_panel_from(p, f"{source}: panel {k}") for k, p in enumerate(raw_panels)]
    stitches = []
    for k, s in enumerate(_list(d.get("stitches", []), source, "stitches")):
        w = f"{source}: stitch {k}"
        _obj(s, w)
        stitches.append(Stitch(
            kind=str(s.get("kind", "seam")), a=_side_from(_need(s, "a", w), w + ".a"),
            b=_side_from(_need(s, "b", w), w + ".b"), orientation=str(s.get("orientation", "reversed")),
            gathered=bool(s.get("gathered", False)), length_a_cm=s.get("length_a_cm"),
            length_b_cm=s.get("length_b_cm"), extra=_rest(s, _STITCH_KEYS)))
    fabric = d.get("fabric", {})
    return Pattern(panels=panels, stitches=stitches, garment_type=_opt_str(d, "garment_type", source),
                   garment_id=_opt_str(d, "garment_id", source), body_id=_opt_str(d, "body_id", source),
                   fabric=dict(_obj(fabric, source + ".fabric")), source_file=source,
                   extra=_rest(d, _PATTERN_KEYS))


def _opt_str(d: dict, key: str, where: str) -> str | None:
    v = d.get(key)
    if v is not None and not isinstance(v, str):
        raise PatternError(f"{where}: {key} must be a string, got {_kind(v)} {_short(v)}".rstrip())
    return v


def read_sewpat(path: str | Path) -> Pattern:
    path = Path(path)
    d = read_json(path, "pattern")
    if not isinstance(d, dict):
        raise PatternError(f"{path}: a sewpat-1 file holds a JSON object")
    return pattern_from_dict(d, str(path))


def _num(x: float) -> float:
    return float(x)


def _edge_to(e: Edge) -> dict:
    extra = dict(e.extra)
    has_ctrl = extra.pop("_has_ctrl", bool(e.ctrl))
    d: dict[str, Any] = {"id": e.id, "start": e.start, "end": e.end, "kind": e.kind,
                         "p0": [_num(c) for c in e.p0], "p1": [_num(c) for c in e.p1]}
    if has_ctrl:
        d["ctrl"] = [[_num(c) for c in p] for p in e.ctrl]
    if e.arc is not None:
        d["arc"] = e.arc
    if e.length_cm is not None:
        d["length_cm"] = e.length_cm
    if e.label is not None:
        d["label"] = e.label
    d.update(extra)
    return d


def _side_to(s: StitchSide) -> dict:
    d: dict[str, Any] = {"panel": s.panel, "range": [int(s.range[0]), int(s.range[1])]}
    if s.edge is not None:
        d["edge"] = s.edge
    if s.landmarks is not None:
        d["landmarks"] = list(s.landmarks)
    d.update(s.extra)
    return d


def pattern_to_dict(p: Pattern) -> dict:
    panels = []
    for pn in p.panels:
        pl = pn.placement
        pd: dict[str, Any] = {
            "name": pn.name, "n_vertices": pn.n_vertices,
            "outline_cm": [[_num(u), _num(v)] for u, v in pn.outline_cm],
            "orientation": pn.orientation, "area_cm2": round(abs(pn.signed_area_cm2()), 3),
            "nodes": list(pn.nodes), "corners": list(pn.corners), "landmarks": dict(pn.landmarks),
            "edges": [_edge_to(e) for e in pn.edges],
            "placement": {"kind": pl.kind, "translation_m": [_num(c) for c in pl.translation_m],
                          "rotation_matrix": [[_num(c) for c in row] for row in pl.rotation],
                          **({"side": pl.side} if pl.side is not None else {}), **pl.extra},
        }
        pd.update(pn.extra)
        panels.append(pd)
    stitches = []
    for s in p.stitches:
        sd: dict[str, Any] = {"kind": s.kind, "a": _side_to(s.a), "b": _side_to(s.b),
                              "orientation": s.orientation, "gathered": s.gathered}
        if s.length_a_cm is not None:
            sd["length_a_cm"] = s.length_a_cm
        if s.length_b_cm is not None:
            sd["length_b_cm"] = s.length_b_cm
        sd.update(s.extra)
        stitches.append(sd)
    d: dict[str, Any] = {"format": FORMAT}
    for key in ("garment_type", "garment_id", "body_id"):
        if getattr(p, key) is not None:
            d[key] = getattr(p, key)
    d["fabric"] = p.fabric
    d.update(p.extra)
    d["panels"] = panels
    d["stitches"] = stitches
    return d


def write_sewpat(pattern: Pattern, path: str | Path) -> Path:
    """Write atomically (temporary file + rename): an existing file is replaced whole or not at all."""
    d = pattern_to_dict(pattern)
    for pn in d["panels"]:
        for u, v in pn["outline_cm"]:
            if not (math.isfinite(u) and math.isfinite(v)):
                raise PatternError(f"{path}: panel {pn['name']!r} has a non-finite outline point; not written")
    return atomic_write_text(Path(path), json.dumps(d, indent=1) + "\n")
