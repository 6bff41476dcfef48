"""Stitches for patterns read from files that have none (DXF): proposals, and the sidecar
JSON in which a user confirms or edits them.

A DXF pattern holds outlines, notches and grain lines but not which edges are sewn
together, nor where the pieces sit around a body. :func:`propose_stitches` pairs runs of
outline between corners whose lengths agree (and whose notches line up); the user marks
the right ones ``"confirmed": true`` in the sidecar, edits or adds others, and the DXF
reader applies the confirmed ones. The sidecar can also give each panel a 3D placement
and the garment type, which grading needs.

Sidecar (``<pattern>.seams.json`` beside ``<pattern>.dxf``, ``<pattern>.aama.dxf`` or
``<pattern>.astm.dxf``; docs/formats.md, "Seams sidecar")::

    {"format": "seamfit-seams-1",
     "garment_type": "skirt",                        (optional)
     "stitches": [
       {"a": {"panel": "Front", "from": [0.0, 0.0], "to": [0.0, 60.0]},
        "b": {"panel": "Back", "from": "corner_2", "to": "corner_3"},
        "orientation": "reversed", "gathered": false, "confirmed": true,
        "length_a_cm": 60.0, "length_b_cm": 60.1, "why": "..."}],
     "placements": {"Front": {"kind": "hint", "rotation_matrix": [[1,0,0],[0,0,-1],[0,1,0]],
                              "translation_m": [0, -0.2, 0.9]}}}

A side runs forward along the panel's outline from ``from`` to ``to``, each either a
point [u, v] in cm (the outline vertex there, within ``SNAP_CM``) or a landmark name.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_text
from .model import Panel, Pattern, Placement, Stitch, StitchSide
from .notches import notch_misses, side_notches
from .sewpat import _PLACEMENT_KEYS

FORMAT = "seamfit-seams-1"
SNAP_CM = 0.05                   # a side's end point must be this close to an outline vertex
MATCH_CM = 0.3                   # runs whose lengths differ by less than this (or ...)
MATCH_REL = 0.01                 # ... this fraction of the longer one) are proposed
_AT = "_at_cm"                   # suffix of the point [u, v] of a placement's landmark
MIN_RUN_CM = 2.0                 # shorter runs (notch slits, corner snips) are not seams
CONGRUENT_REL = 0.005            # panels whose area and perimeter agree this closely are copies


def sidecar_path(dxf_path: str | Path) -> Path:
    """``skirt.seams.json`` for ``skirt.dxf``, ``skirt.aama.dxf`` and ``skirt.astm.dxf``."""
    p = Path(dxf_path)
    stem = p.name[:-4] if p.name.lower().endswith(".dxf") else p.stem
    for flavor in (".aama", ".astm"):
        if stem.lower().endswith(flavor):
            stem = stem[: -len(flavor)]
    return p.with_name(stem + ".seams.json")


# ----------------------------------------------------------------------------- proposals

def _runs(panel: Panel) -> list[tuple[int, int, float, list[float]]]:
    """(i0, i1, length cm, notch positions in cm from i0) of each run between corners."""
    cuts = sorted(set(panel.corners)) or [0]
    out = []
    for k, i0 in enumerate(cuts):
        i1 = cuts[(k + 1) % len(cuts)]
        found, length = side_notches(panel, (i0, i1))
        out.append((i0, i1, length, [s for _, s in found]))
    return out


def _congruent(a: Panel, b: Panel) -> bool:
    def perim(p):
        o = p.outline_cm
        return float(np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1).sum())
    aa, ab = abs(a.signed_area_cm2()), abs(b.signed_area_cm2())
    return abs(aa - ab) <= CONGRUENT_REL * max(aa, ab) and abs(perim(a) - perim(b)) <= CONGRUENT_REL * max(perim(a), perim(b))


def propose_stitches(pattern: Pattern) -> list[dict[str, Any]]:
    """Sidecar entries (``confirmed: false``) pairing runs between corners of equal length.

    Each run is used once; the best-scored pairs go first. The score is the length
    difference as a fraction of the run, lowered when the notches of both sides line up
    (read towards each other, as right sides together are sewn: ``reversed``) and raised
    when they do not, when the two panels are copies of each other (the left and right
    of one piece share every length, yet are seldom sewn edge to edge) or when both runs
    are on one panel."""
    runs = [(p, r) for p in pattern.panels for r in _runs(p) if r[2] >= MIN_RUN_CM]
    cands = []
    for x in range(len(runs)):
        pa, ra = runs[x]
        for y in range(x + 1, len(runs)):
            pb, rb = runs[y]
            if pa is pb and (ra[0] == rb[1] or ra[1] == rb[0]):
                continue                         # neighbours on one panel meet at a corner
            la, lb = ra[2], rb[2]
            diff = abs(la - lb)
            if diff > max(MATCH_CM, MATCH_REL * max(la, lb)):
                continue
            score = diff / max(la, lb)
            why = [f"lengths {la:.2f} and {lb:.2f} cm"]
            misses = []
            if ra[3] or rb[3]:
                misses = notch_misses(pa, (ra[0], ra[1]), pb, (rb[0], rb[1]))
                if not misses:
                    score -= 0.02 * len(ra[3])
                    why.append(f"{len(ra[3])} notch(es) line up")
                else:
                    score += 0.05
                    why.append(f"notches differ ({len(ra[3])} and {len(rb[3])})")
            if pa is not pb and _congruent(pa, pb):
                score += 0.1
                why.append("the panels are copies of each other")
            elif pa is pb:                       # a sleeve's underarm, but mostly chance
                score += 0.1
                why.append("both on one panel")
            cands.append((score, x, y, "; ".join(why), [m.describe() for m in misses]))
    cands.sort(key=lambda c: (c[0], c[1], c[2]))
    used: set[int] = set()
    out = []
    for score, x, y, why, notch_warnings in cands:
        if x in used or y in used:
            continue
        used.update((x, y))
        (pa, ra), (pb, rb) = runs[x], runs[y]
        out.append({"a": _side_dict(pa, ra[0], ra[1]), "b": _side_dict(pb, rb[0], rb[1]),
                    "orientation": "reversed", "gathered": False, "confirmed": False,
                    "length_a_cm": round(ra[2], 4), "length_b_cm": round(rb[2], 4),
                    "score": round(score, 5), "why": why,
                    **({"notch_warnings": notch_warnings} if notch_warnings else {})})
    return out


def _side_dict(panel: Panel, i0: int, i1: int) -> dict[str, Any]:
    o = panel.outline_cm
    return {"panel": panel.name, "from": [round(float(o[i0, 0]), 6), round(float(o[i0, 1]), 6)],
            "to": [round(float(o[i1, 0]), 6), round(float(o[i1, 1]), 6)]}


# ----------------------------------------------------------------------------- sidecar

def sidecar_dict(pattern: Pattern, proposals: list[dict] | None = None) -> dict[str, Any]:
    """The sidecar for ``pattern``: its stitches (confirmed), then ``proposals``, and the
    placements of panels placed in 3D."""
    from .refit import side_length_cm
    panels = {p.name: p for p in pattern.panels}
    stitches = []
    for s in pattern.stitches:
        entry: dict[str, Any] = {}
        for key, side in (("a", s.a), ("b", s.b)):
            p = panels.get(side.panel)
            if p is None:
                raise PatternError(f"stitch side on unknown panel {side.panel!r}")
            entry[key] = _side_dict(p, *side.range)
        entry.update({"orientation": s.orientation, "gathered": bool(s.gathered), "confirmed": True,
                      "kind": s.kind,
                      "length_a_cm": round(side_length_cm(panels[s.a.panel], s.a.range), 4),
                      "length_b_cm": round(side_length_cm(panels[s.b.panel], s.b.range), 4)})
        stitches.append(entry)
    d: dict[str, Any] = {"format": FORMAT}
    if pattern.garment_type:
        d["garment_type"] = pattern.garment_type
    d["stitches"] = stitches + list(proposals or [])
    placements = {}
    for p in pattern.panels:
        pl = p.placement
        if _default_placement(pl):
            continue                             # nothing to say
        # the placement's other keys too (the dressing's anchor_landmark, body_side, ...); a
        # landmark named there also by its point, since DXF keeps no landmark names
        entry = {"kind": pl.kind, "rotation_matrix": np.asarray(pl.rotation, float).tolist(),
                 "translation_m": np.asarray(pl.translation_m, float).tolist(),
                 **({"side": pl.side} if pl.side else {}),
                 **{k: v for k, v in (pl.extra or {}).items() if k not in _PLACEMENT_KEYS}}
        for key in [k for k in entry if k.endswith("_landmark")]:
            v = p.landmarks.get(entry[key]) if isinstance(entry[key], str) else None
            if isinstance(v, (int, np.integer)) and 0 <= v < len(p.outline_cm):
                entry[key + _AT] = [round(float(c), 6) for c in p.outline_cm[v]]
        placements[p.name] = entry
    if placements:
        d["placements"] = placements
    return d


def write_sidecar(path: str | Path, d: dict[str, Any]) -> Path:
    text = json.dumps(d, indent=1, ensure_ascii=False)
    # points and matrix rows on one line each: the file is for people to read and edit
    text = re.sub(r"\[\s+(-?[0-9][0-9.eE+-]*),\s+(-?[0-9][0-9.eE+-]*)(?:,\s+(-?[0-9][0-9.eE+-]*))?\s+\]",
                  lambda m: "[" + ", ".join(g for g in m.groups() if g is not None) + "]", text)
    return atomic_write_text(Path(path), text + "\n")


def read_sidecar(path: str | Path) -> dict[str, Any]:
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PatternError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PatternError(f"{path}: cannot read the seams file ({getattr(exc, 'strerror', None) or exc})") from None
    except json.JSONDecodeError as exc:
        raise PatternError(f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise PatternError(f"{path}: not a seams file (expected a JSON object with \"format\": \"{FORMAT}\")")
    if not isinstance(d.get("stitches", []), list) or not isinstance(d.get("placements", {}), dict):
        raise PatternError(f"{path}: 'stitches' must be a list and 'placements' an object")
    return d


def apply_sidecar(pattern: Pattern, path: str | Path) -> int:
    """Set the pattern's stitches to the sidecar's confirmed ones, its placements and garment
    type; returns the number of stitches. PatternError names the file and the entry at fault."""
    from .refit import side_length_cm
    path = Path(path)
    d = read_sidecar(path)
    panels = {p.name: p for p in pattern.panels}
    stitches = []
    for k, s in enumerate(d.get("stitches", [])):
        where = f"{path}: stitch {k}"
        if not isinstance(s, dict):
            raise PatternError(f"{where}: must be a JSON object")
        if not s.get("confirmed", False):
            continue
        sides = []
        for key in ("a", "b"):
            side = s.get(key)
            if not isinstance(side, dict):
                raise PatternError(f"{where}: side {key!r} must be an object with panel, from, to")
            name = side.get("panel")
            if name not in panels:
                raise PatternError(f"{where} side {key}: no panel {name!r} in the pattern "
                                   f"(panels: {', '.join(map(repr, panels))})")
            p = panels[name]
            i0 = _vertex(p, side.get("from"), f"{where} side {key} 'from'")
            i1 = _vertex(p, side.get("to"), f"{where} side {key} 'to'")
            if i0 == i1:
                raise PatternError(f"{where} side {key}: 'from' and 'to' are the same outline vertex {i0}")
            sides.append(StitchSide(panel=name, range=(i0, i1)))
        orient = s.get("orientation", "reversed")
        if orient not in ("reversed", "same"):
            raise PatternError(f"{where}: orientation must be 'reversed' or 'same', not {orient!r}")
        kind = s.get("kind") or ("dart_or_internal" if sides[0].panel == sides[1].panel else "seam")
        st = Stitch(kind=str(kind), a=sides[0], b=sides[1], orientation=orient, gathered=bool(s.get("gathered", False)))
        st.length_a_cm = round(side_length_cm(panels[st.a.panel], st.a.range), 4)
        st.length_b_cm = round(side_length_cm(panels[st.b.panel], st.b.range), 4)
        stitches.append(st)
    for name, pl in (d.get("placements") or {}).items():
        where = f"{path}: placement of {name!r}"
        if name not in panels:
            raise PatternError(f"{where}: no such panel in the pattern")
        try:
            rot = np.asarray(pl["rotation_matrix"], dtype=float).reshape(3, 3)
            tr = np.asarray(pl["translation_m"], dtype=float).reshape(3)
        except (KeyError, TypeError, ValueError):
            raise PatternError(f"{where}: needs rotation_matrix (3x3) and translation_m (3 numbers)") from None
        if not (np.all(np.isfinite(rot)) and np.all(np.isfinite(tr))):
            raise PatternError(f"{where}: non-finite numbers")
        panel = panels[name]
        for key in [k for k in pl if k.endswith("_landmark")]:
            mark = pl[key]
            if not isinstance(mark, str):
                raise PatternError(f"{where}: {key} must be a landmark name")
            if mark in panel.landmarks:
                continue
            if key + _AT not in pl:
                raise PatternError(f"{where}: {key} {mark!r} is not a landmark of the panel (landmarks: "
                                   f"{', '.join(panel.landmarks) or 'none'}); name one, or give its point as "
                                   f"{key + _AT} [u, v]")
            panel.landmarks[mark] = _vertex(panel, pl[key + _AT], f"{where} {key + _AT}")
        panel.placement = Placement(kind=str(pl.get("kind", "hint")), rotation=rot, translation_m=tr,
                                    side=pl.get("side"),
                                    extra={k: v for k, v in pl.items()
                                           if k not in _PLACEMENT_KEYS and not k.endswith(_AT)})
    if d.get("garment_type"):
        pattern.garment_type = str(d["garment_type"])
    pattern.stitches = stitches
    return len(stitches)


def check_drapable(pattern: Pattern) -> None:
    """A pattern read from a DXF is draped (drape, grade, grade-run) only with its stitches
    and every panel's placement from the seams sidecar: without them the drape runs long and
    fails far from the cause. PatternError naming the file, the sidecar and the panels."""
    source = pattern.extra.get("source") or {}
    if not str(source.get("format", "")).startswith("dxf"):
        return
    src = pattern.source_file or "<pattern>"
    side = source.get("seams") or sidecar_path(src).name
    if not pattern.stitches:
        raise PatternError(f"{src}: no stitches (DXF has none): confirm them in the seams sidecar {side} "
                           "(seamfit convert FILE --propose-seams SEAMS.json proposes them)")
    unplaced = [p.name for p in pattern.panels if _default_placement(p.placement)]
    if unplaced:
        raise PatternError(f"{src}: no placement for {len(unplaced)} panel(s) ({', '.join(map(repr, unplaced))}; DXF "
                           f"has none): give each its place around the body in the seams sidecar {side} "
                           "(docs/formats.md, \"Grading a DXF\")")


def _default_placement(pl: Placement) -> bool:
    """The DXF reader's placement: a hint at the origin, unrotated (no place at all)."""
    return pl.kind == "hint" and np.allclose(pl.rotation, np.eye(3)) and not np.any(pl.translation_m)


def _vertex(panel: Panel, ref, where: str) -> int:
    if isinstance(ref, str):
        if ref not in panel.landmarks:
            raise PatternError(f"{where}: panel {panel.name!r} has no landmark {ref!r}")
        return int(panel.landmarks[ref])
    if not (isinstance(ref, list) and len(ref) == 2 and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                                                            and math.isfinite(c) for c in ref)):
        raise PatternError(f"{where}: must be a point [u, v] in cm or a landmark name")
    d = np.linalg.norm(np.asarray(panel.outline_cm, dtype=float) - np.asarray(ref, dtype=float), axis=1)
    i = int(np.argmin(d))
    if d[i] > SNAP_CM:
        raise PatternError(f"{where}: panel {panel.name!r} has no outline vertex within {SNAP_CM * 10:g} mm of "
                           f"({ref[0]:g}, {ref[1]:g}) cm (nearest {d[i]:.2f} cm away)")
    return i
