"""DXF-AAMA and DXF-ASTM (ASTM D6673) pattern files: read into a :class:`Pattern`, write one.

The apparel exchange conventions lay every piece out as one BLOCK, inserted once in model
space, with its parts on numbered layers:

====== =====================================================================
layer  what
====== =====================================================================
1      boundary: the cut line (with seam allowance) or, without allowance, the seam line;
       piece texts (``Piece Name:``, ``Size:``, ``Category:``, ``Quantity:``, free text)
2      turn points (corners), POINT entities
4      notches: a LINE from the boundary into the piece (or a POINT on it)
7      grain line
8      internal lines (darts, pocket placement); Valentina's AAMA export also writes the
       seam line here
11     internal cutouts
13     drill holes (POINT or CIRCLE)
14     sew line (the seam line of a piece with seam allowance)
15     ASTM annotation text
80-83  ASTM notch types (T, castle, check, U)
84-87  ASTM quality-validation copies of layers 1, 8, 11, 14 (ignored on reading)
====== =====================================================================

Mapping to sewpat-1 (docs/formats.md, "DXF"): the seam line becomes the panel outline, in
cm; every vertex of the DXF polyline is kept, and points are added on its straight
segments longer than 1.5 cm so that samples are at most 1 cm apart there. Edges are fitted between corners: a
``line`` where the run is straight, otherwise ``cubic`` curves, each within
``FIT_TOL_CM`` of the polyline's vertices (a run that one cubic cannot follow is split).
Notches become outline vertices listed in the panel's ``notches``; the grain line, drill
holes, internal lines and cutouts are kept in the panel (``grain_line_cm``,
``drill_holes_cm``, ``internal_lines``, ``cutouts``); the cut line is kept with the
per-edge seam allowance measured from it. DXF has no stitches and no 3D placement:
seamfit.pattern.seams proposes the stitches and reads them (and placements) from a
sidecar JSON file.
"""
from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_bytes
from .model import Edge, Panel, Pattern, Placement

FLAVORS = ("aama", "astm")
UNITS_CM = {"in": 2.54, "mm": 0.1, "cm": 1.0, "m": 100.0}
_INSUNITS = {1: "in", 4: "mm", 5: "cm", 6: "m"}
_UNITS_CODE = {v: k for k, v in _INSUNITS.items()}

SAMPLE_SPACING_CM = 1.0          # outline samples at most this far apart (sewpat-1's rule) ...
# ... where the file's segments are longer than this: a graded outline, stretched a little
# past 1 cm between samples, reads back with the same points
SPLIT_ABOVE_CM = 1.5
# Edge fit: every DXF vertex within 0.05 mm of its edge's curve, half the 0.1 mm a round
# trip may move a point; and the curve within 0.5 mm (refit's tolerance) of the midpoints
# of the polyline's segments, so that a curve does not wander between sparse vertices.
FIT_TOL_CM = 0.005
FIT_CHORD_TOL_CM = 0.05
CORNER_ANGLE_DEG = 12.0          # as the other readers: a tangent break beyond this is a corner
CORNER_SURE_DEG = 40.0           # a turn this sharp is a corner even inside a coarse curve
SAME_POINT_CM = 1e-5             # closer DXF vertices are one point
CLOSE_GAP_CM = 0.05              # a boundary whose ends are closer than this is closed
NOTCH_ON_LINE_CM = 0.5           # a notch farther than this from the seam and cut lines is an error
DEFAULT_NOTCH_DEPTH_CM = 0.6     # a 6 mm slit, the common notch
PIECE_MIN_CM, PIECE_MAX_CM = 0.5, 1000.0   # plausible extent of a pattern piece
FAR_CM = 1000.0                  # a piece farther than 10 m from the origin is moved to it
CUT_LINE_MAX_ALLOWANCE_CM = 20.0  # a cut line farther than this from the seam line is broken

_QUALITY_LAYERS = {"84", "85", "86", "87"}
_NOTCH_TYPES = {"4": "slit", "80": "T", "81": "castle", "82": "check", "83": "U"}
_TEXT_KEYS = {"piece name": "name", "size": "size", "category": "category", "quantity": "quantity",
              "material": "material", "rotation": "rotation", "annotation": "annotation",
              "style name": "style", "grade rule table": "grade_rule_table",
              "sample size": "sample_size", "units": "units", "author": "author",
              "creation date": "creation_date"}


@dataclass
class DxfReadResult:
    """What :func:`read_dxf_file` returns: the pattern and notes on what was dropped or guessed."""
    pattern: Pattern
    flavor: str
    units: str
    notes: list[str] = field(default_factory=list)


# ============================================================================ reading

def read_dxf(path: str | Path, *, units: str | None = None) -> Pattern:
    """The pattern in a DXF-AAMA/ASTM file (see the module doc); PatternError naming the file
    (and piece) when it is not a readable pattern DXF."""
    return read_dxf_file(path, units=units).pattern


def read_dxf_file(path: str | Path, *, units: str | None = None) -> DxfReadResult:
    """Every piece of the file in one pattern, repeated names made unique (`` 2``, `` 3``, ...)."""
    res = read_dxf_pieces(path, units=units)
    unique_names(res.pattern.panels)
    return res


def unique_names(panels: list[Panel]) -> None:
    """Rename repeats of a panel name in place: the second ``Detail`` becomes ``Detail 2``."""
    taken: set[str] = set()
    for panel in panels:
        unique, j = panel.name, 2
        while unique in taken:
            unique = f"{panel.name} {j}"
            j += 1
        taken.add(unique)
        panel.name = unique


def read_dxf_pieces(path: str | Path, *, units: str | None = None) -> DxfReadResult:
    """The file's pieces as panels named as the file names them (names may repeat: a
    multi-size file holds each piece once per size; seamfit.pattern.dxf_sizes groups them)."""
    path = Path(path)
    if units is not None and units not in UNITS_CM:
        raise PatternError(f"{path}: unknown DXF units {units!r} (expected one of {', '.join(UNITS_CM)})")
    doc = _load_doc(path)
    header_texts, pieces = _pieces(doc, path)
    flavor = _flavor(pieces)
    unit, unit_from = _units(doc, header_texts, units, path)
    scale = UNITS_CM[unit]
    notes: list[str] = []
    panels = [_panel(piece, k, scale, unit, unit_from, path, notes) for k, piece in enumerate(pieces)]
    if not panels:
        raise PatternError(f"{path}: no pattern pieces (no block with a boundary on layer 1)")
    info = {key: val for key, val in header_texts.items() if key != "units"}
    extra: dict[str, Any] = {"source": {"format": f"dxf-{flavor}", "units": unit, "file": path.name}}
    if info:
        extra["dxf"] = {"header": info}
    if "style" in info:
        extra["style_name"] = info["style"]
    pattern = Pattern(panels=panels, stitches=[], garment_type=None, garment_id=info.get("style"),
                      source_file=str(path), extra=extra)
    return DxfReadResult(pattern=pattern, flavor=flavor, units=unit, notes=notes)


def _load_doc(path: Path):
    import ezdxf
    from ezdxf import recover
    from ezdxf.lldxf.const import DXFError

    from ..limits import check_readable_file
    check_readable_file(path, "pattern", "a DXF file", PatternError)
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as exc:
        raise PatternError(f"{path}: cannot read ({exc.strerror})") from exc
    if not head.strip():
        raise PatternError(f"{path}: empty file; expected a DXF (AAMA/ASTM) pattern")
    import logging
    log = logging.getLogger("ezdxf")
    level = log.level
    log.setLevel(logging.ERROR)             # repaired handles are no news to a user
    try:
        # recover: exports in the wild repeat block names and handles (Valentina does)
        doc, _auditor = recover.readfile(str(path))
    except (DXFError, ezdxf.DXFStructureError) as exc:
        raise PatternError(f"{path}: not a readable DXF file ({' '.join(str(exc).split())[:160]})") from None
    except (UnicodeDecodeError, ValueError, IndexError, TypeError) as exc:
        raise PatternError(f"{path}: not a readable DXF file ({type(exc).__name__})") from None
    finally:
        log.setLevel(level)
    doc.filename = str(path)
    return doc


@dataclass
class _Piece:
    block: str
    entities: list
    matrix: Any            # ezdxf Matrix44 block -> piece coordinates (no translation), or None
    insert: tuple[float, float]


def _raw_blocks(path: Path) -> tuple[list[tuple[str, list[str]]], list[tuple[str, str]]]:
    """Blocks in file order as (name, entity handles) and model-space INSERTs as (block
    name, handle), from the tag stream: the document merges blocks that share a name."""
    from ezdxf.lldxf.tagger import ascii_tags_loader
    blocks: list[tuple[str, list[str]]] = []
    inserts: list[tuple[str, str]] = []
    section = None
    current: list[str] | None = None
    entity = None                    # structure tag of the entity being read
    want_name = False
    want_handle = False
    insert_name = insert_handle = None
    with open(path, encoding="cp1252", errors="replace") as f:
        for tag in ascii_tags_loader(f):
            code, value = tag.code, tag.value
            if code == 0:
                if entity == "INSERT" and section == "ENTITIES" and insert_name is not None:
                    inserts.append((insert_name, insert_handle))
                entity, insert_name, insert_handle = value, None, None
                want_handle = True
                if value == "SECTION":
                    section = None
                elif value == "BLOCK" and section == "BLOCKS":
                    current = []
                    blocks.append(("", current))
                    want_name = True
                elif value == "ENDBLK":
                    current = None
                continue
            if entity == "SECTION" and code == 2:
                section = value
            elif entity == "BLOCK" and want_name and code == 2:
                blocks[-1] = (value, current)
                want_name = False
            elif code == 5 and want_handle:
                want_handle = False
                if current is not None and entity not in ("BLOCK", "ENDBLK"):
                    current.append(value)
                if entity == "INSERT":
                    insert_handle = value
            elif entity == "INSERT" and code == 2 and insert_name is None:
                insert_name = value
    if entity == "INSERT" and section == "ENTITIES" and insert_name is not None:
        inserts.append((insert_name, insert_handle))
    return blocks, inserts


def _pieces(doc, path: Path) -> tuple[dict[str, str], list[_Piece]]:
    """Model-space header texts and the pattern pieces: every block inserted in model space
    (each INSERT of a repeated name takes the next block of that name), or every block
    with entities when nothing is inserted."""
    header: dict[str, str] = {}
    msp = doc.modelspace()
    for e in msp:
        if e.dxftype() in ("TEXT", "MTEXT"):
            key, val = _text_field(_plain_text(e))
            if key and val:
                header.setdefault(key, val)
    try:
        raw_blocks, raw_inserts = _raw_blocks(path)
    except (OSError, UnicodeError, ValueError):
        raw_blocks, raw_inserts = [], []          # a binary DXF: the document's blocks
    db = doc.entitydb
    by_name: dict[str, list[list]] = {}
    for name, handles in raw_blocks:
        ents = [db.get(h) for h in handles]
        if name.startswith("*") or not handles or any(e is None for e in ents):
            continue
        by_name.setdefault(name, []).append(ents)
    if not by_name:                               # tags not usable: trust the document
        for blk in doc.blocks:
            if not blk.name.startswith("*") and len(blk):
                by_name.setdefault(blk.name, []).append(list(blk))
    inserts = [e for e in msp if e.dxftype() == "INSERT"]
    order = {h: k for k, (_, h) in enumerate(raw_inserts)}
    inserts.sort(key=lambda e: order.get(e.dxf.handle, len(order)))
    pieces: list[_Piece] = []
    used: dict[str, int] = {}
    for ins in inserts:
        name = ins.dxf.name
        copies = by_name.get(name)
        if not copies:
            continue
        k = used.get(name, 0)
        if k >= len(copies):
            k = len(copies) - 1               # one block inserted twice: a second copy
        used[name] = k + 1
        pieces.append(_Piece(name, copies[k], _insert_matrix(ins, doc), _xy(ins.dxf.insert)))
    if not inserts:
        for name, copies in by_name.items():
            for ents in copies:
                pieces.append(_Piece(name, ents, None, (0.0, 0.0)))
    from ..limits import PANELS
    PANELS.check(len(pieces), str(path), error=PatternError)
    return header, pieces


def _insert_matrix(ins, doc):
    """The INSERT's scale, rotation and block base point, without its insertion point (which
    is the piece's place on the marker, kept apart)."""
    from ezdxf.math import Matrix44
    sx, sy = float(ins.dxf.get("xscale", 1.0)), float(ins.dxf.get("yscale", 1.0))
    rot = math.radians(float(ins.dxf.get("rotation", 0.0)))
    base = (0.0, 0.0)
    blk = doc.blocks.get(ins.dxf.name)
    if blk is not None:
        base = _xy(blk.block.dxf.get("base_point", (0.0, 0.0, 0.0)))
    if sx == 1.0 and sy == 1.0 and rot == 0.0 and base == (0.0, 0.0):
        return None
    return Matrix44.chain(Matrix44.translate(-base[0], -base[1], 0.0), Matrix44.scale(sx, sy, 1.0),
                          Matrix44.z_rotate(rot))


def _xy(v) -> tuple[float, float]:
    return (float(v[0]), float(v[1]))


def _plain_text(e) -> str:
    text = e.plain_text() if e.dxftype() == "MTEXT" else str(e.dxf.get("text", ""))
    return re.sub(r"\\U\+([0-9A-Fa-f]{4})", lambda m: chr(int(m.group(1), 16)), text).strip()


def _text_height(e, scale: float) -> float:
    key = "char_height" if e.dxftype() == "MTEXT" else "height"
    try:
        return float(e.dxf.get(key, 0.0)) * scale
    except (TypeError, ValueError):
        return 0.0


def _text_field(text: str) -> tuple[str | None, str]:
    """('name', 'Front') for 'Piece Name: Front'; (None, text) for free text."""
    m = re.match(r"\s*([A-Za-z][A-Za-z ]*?)\s*:\s*(.*)$", text)
    if m and m.group(1).lower() in _TEXT_KEYS:
        return _TEXT_KEYS[m.group(1).lower()], m.group(2).strip()
    return None, text


def _flavor(pieces: list[_Piece]) -> str:
    for p in pieces:
        for e in p.entities:
            if e.dxf.layer in _QUALITY_LAYERS or e.dxf.layer == "15":
                return "astm"
    return "aama"


def _units(doc, texts: dict[str, str], forced: str | None, path: Path) -> tuple[str, str]:
    if forced:
        return forced, "--dxf-units"
    code = doc.header.get("$INSUNITS", 0)
    if code in _INSUNITS:
        return _INSUNITS[code], f"$INSUNITS {code}"
    t = texts.get("units", "").strip().lower()
    if t:
        if t.startswith(("english", "inch", "imperial")):
            return "in", f"text 'Units: {texts['units']}'"
        if t.startswith(("metric", "mm", "millimet")):
            return "mm", f"text 'Units: {texts['units']}'"
        if t.startswith(("cm", "centimet")):
            return "cm", f"text 'Units: {texts['units']}'"
        raise PatternError(f"{path}: unknown units text 'Units: {texts['units']}' (expected METRIC or "
                           "ENGLISH); give the units with --dxf-units")
    if code not in (0, None):
        raise PatternError(f"{path}: $INSUNITS {code} is not a pattern unit (inch 1, mm 4, cm 5, m 6); "
                           "give the units with --dxf-units")
    meas = doc.header.get("$MEASUREMENT", None)
    if meas == 0:
        return "in", "$MEASUREMENT 0 (imperial)"
    return "mm", "the default (no units in the header or text)"


# ----------------------------------------------------------------------- geometry

def _entity_points(e, m44, scale: float) -> list[tuple[np.ndarray, bool]]:
    """(points in cm, closed) for each polyline an entity holds."""
    t = e.dxftype()
    if t == "LINE":
        pts = np.array([_xy(e.dxf.start), _xy(e.dxf.end)])
        closed = False
    elif t == "LWPOLYLINE" and not any(b for *_, b in e.get_points("xyb")):
        pts = np.array(e.get_points("xy"), dtype=float).reshape(-1, 2)
        closed = bool(e.closed)
    elif t == "POLYLINE" and e.is_2d_polyline and not any(v.dxf.get("bulge", 0) for v in e.vertices):
        pts = np.array([_xy(v) for v in e.points()], dtype=float).reshape(-1, 2)
        closed = bool(e.is_closed)
    elif t in ("LWPOLYLINE", "POLYLINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE"):
        from ezdxf import path as ezpath
        p = ezpath.make_path(e)
        pts = np.array([_xy(v) for v in p.flattening(distance=0.001 / scale)], dtype=float).reshape(-1, 2)
        closed = t in ("CIRCLE",) or bool(getattr(e, "closed", False) or getattr(e, "is_closed", False))
    else:
        return []
    if m44 is not None and len(pts):
        pts = np.array([_xy(v) for v in m44.transform_vertices([(x, y, 0.0) for x, y in pts])])
    pts = pts * scale
    if not np.all(np.isfinite(pts)):
        return []
    return [(pts, closed)]


def _dedup(pts: np.ndarray, closed: bool) -> np.ndarray:
    keep = np.ones(len(pts), dtype=bool)
    last = 0
    for i in range(1, len(pts)):
        if np.linalg.norm(pts[i] - pts[last]) <= SAME_POINT_CM:
            keep[i] = False
        else:
            last = i
    out = pts[keep]
    if closed and len(out) > 1 and np.linalg.norm(out[-1] - out[0]) <= SAME_POINT_CM:
        out = out[:-1]
    return out


def _chain(parts: list[tuple[np.ndarray, bool]]) -> list[tuple[np.ndarray, bool]]:
    """Join open pieces end to end (either direction) into longer runs; a run whose ends
    meet is closed."""
    closed = [(_dedup(p, True), True) for p, c in parts if c]
    open_ = [p for p, c in parts if not c and len(p) >= 2]
    runs: list[tuple[np.ndarray, bool]] = []
    while open_:
        run = open_.pop(0)
        grown = True
        while grown:
            grown = False
            for k, q in enumerate(open_):
                for cand in (q, q[::-1]):
                    if np.linalg.norm(cand[0] - run[-1]) <= CLOSE_GAP_CM:
                        run = np.vstack([run, cand[1:]])
                    elif np.linalg.norm(cand[-1] - run[0]) <= CLOSE_GAP_CM:
                        run = np.vstack([cand[:-1], run])
                    else:
                        continue
                    open_.pop(k)
                    grown = True
                    break
                if grown:
                    break
        is_closed = len(run) > 2 and np.linalg.norm(run[-1] - run[0]) <= CLOSE_GAP_CM
        runs.append((_dedup(run, is_closed), is_closed))
    return closed + runs


def _area(o: np.ndarray) -> float:
    u, v = o[:, 0], o[:, 1]
    return 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v))


def _dist_to_polyline(points: np.ndarray, poly: np.ndarray, closed: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance of each point to the polyline, the segment index of the nearest point and
    its fraction along that segment."""
    a = poly
    b = np.roll(poly, -1, axis=0) if closed else poly[1:]
    a = a if closed else poly[:-1]
    ab = b - a
    ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    d = np.empty(len(points))
    seg = np.empty(len(points), dtype=int)
    frac = np.empty(len(points))
    for i, p in enumerate(points):
        w = np.clip(np.einsum("ij,ij->i", p - a, ab) / ab2, 0.0, 1.0)
        dist = np.linalg.norm(a + w[:, None] * ab - p, axis=1)
        k = int(np.argmin(dist))
        d[i], seg[i], frac[i] = dist[k], k, w[k]
    return d, seg, frac


def _turns_deg(o: np.ndarray) -> np.ndarray:
    d_in = o - np.roll(o, 1, axis=0)
    d_out = np.roll(o, -1, axis=0) - o
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    dot = np.einsum("ij,ij->i", d_in, d_out)
    return np.degrees(np.abs(np.arctan2(cross, dot)))


def _corner_vertices(o: np.ndarray, hints: list[int]) -> list[int]:
    """Corners of a closed polyline: turn points given in the file, and vertices whose turn
    is sharp, or beyond CORNER_ANGLE_DEG and clearly sharper than both neighbours' (a
    flattened curve turns a little at every vertex, a corner at one)."""
    turn = _turns_deg(o)
    prev, nxt = np.roll(turn, 1), np.roll(turn, -1)
    sharp = (turn > CORNER_SURE_DEG) | ((turn > CORNER_ANGLE_DEG) & (turn > 2.0 * np.maximum(prev, nxt)))
    return sorted(set(np.nonzero(sharp)[0].tolist()) | set(hints))


# ----------------------------------------------------------------------- edge fitting

def _fit_run(pts: np.ndarray, force: bool = False) -> tuple[str, list[tuple[float, float]]] | None:
    """('line', []) or ('cubic', ctrl) fitting the run within tolerance, else None (with
    ``force``, the best cubic whatever its distance)."""
    from .refit import _chord_params, _fit_bezier, _reparametrize, _solve_ctrl
    p0, p1 = pts[0], pts[-1]
    chord = p1 - p0
    n = float(np.linalg.norm(chord))
    if n <= SAME_POINT_CM:
        return None
    inner = pts[1:-1]
    off = np.abs((inner - p0) @ np.array([-chord[1], chord[0]]) / n) if len(inner) else np.zeros(0)
    along = (inner - p0) @ chord / (n * n) if len(inner) else np.zeros(0)
    if np.all(off <= FIT_TOL_CM) and np.all((along > 0) & (along < 1)) and np.all(np.diff(along) > 0):
        return "line", []
    if len(pts) < 3:
        return None
    prior = p0 + np.outer([1.0 / 3.0, 2.0 / 3.0], chord)
    # linear least squares with projection steps first; the costlier joint polish only
    # for a run that comes close
    t = _chord_params(pts)
    cp = _solve_ctrl(3, pts, t, prior)
    for _ in range(6):
        t = _reparametrize(cp, pts, t)
        cp = _solve_ctrl(3, pts, t, prior)
    dev = _cubic_deviation(cp, inner)
    if dev > FIT_TOL_CM and (force or dev < 4.0 * FIT_TOL_CM):
        cp2 = _fit_bezier(3, pts, prior, [_chord_params(pts)], FIT_TOL_CM)
        dev2 = _cubic_deviation(cp2, inner)
        if dev2 < dev:
            cp, dev = cp2, dev2
    ctrl = [(float(c[0]), float(c[1])) for c in cp[1:-1]]
    if force:
        return "cubic", ctrl
    if dev > FIT_TOL_CM:
        return None
    mids = 0.5 * (pts[:-1] + pts[1:])
    if _cubic_deviation(cp, mids) > FIT_CHORD_TOL_CM:
        return None
    return "cubic", ctrl


def _cubic_deviation(cp: np.ndarray, pts: np.ndarray) -> float:
    from .refit import project_onto_curve
    if len(pts) == 0:
        return 0.0
    e = Edge(id=0, start=0, end=1, kind="cubic", p0=tuple(cp[0]), p1=tuple(cp[-1]),
             ctrl=[tuple(c) for c in cp[1:-1]])
    on, _ = project_onto_curve(e, pts)
    return float(np.linalg.norm(on - pts, axis=1).max())


def _fit_edges(o: np.ndarray, corners: list[int]) -> list[tuple[int, int, str, list]]:
    """(start, end, kind, ctrl) over raw vertex indices, wrapping: runs between corners
    fitted greedily by the longest line or cubic that meets the tolerance."""
    n = len(o)
    starts = corners if corners else [0]
    out = []
    for k, c0 in enumerate(starts):
        c1 = starts[(k + 1) % len(starts)]
        span = (c1 - c0) % n or n
        i = 0
        while i < span:
            lo, hi = i + 1, span            # lo always fits (a single segment is a line)
            best = ("line", [])
            if hi > lo:
                fit = _fit_run(o[(c0 + np.arange(i, hi + 1)) % n])
                if fit is not None:
                    lo, best = hi, fit
            while hi - lo > 0 and lo < span:
                mid = (lo + hi + 1) // 2
                fit = _fit_run(o[(c0 + np.arange(i, mid + 1)) % n])
                if fit is not None:
                    lo, best = mid, fit
                else:
                    hi = mid - 1
            out.append(((c0 + i) % n, (c0 + lo) % n, best[0], best[1]))
            i = lo
    return out


def build_panel_geometry(raw: np.ndarray, corner_hints: list[int], node_hints: list[int] | None = None
                         ) -> tuple[np.ndarray, list[Edge], list[int], list[int], np.ndarray]:
    """From a closed polyline (cm, no repeated closing point): the outline with points added
    on long segments, the fitted edges, nodes, corners, and the outline index of each raw
    vertex. With turn or curve points from the file (``corner_hints``, ``node_hints``: raw
    vertex indices), the edges run between exactly those; otherwise corners are found by
    angle and the runs between them split where one curve cannot follow them."""
    if corner_hints or node_hints:
        corners_raw = sorted(set(corner_hints))
        nodes_raw = sorted(set(corner_hints) | set(node_hints or []))
        fits = []
        for k, a in enumerate(nodes_raw):
            b = nodes_raw[(k + 1) % len(nodes_raw)]
            span = (b - a) % len(raw) or len(raw)
            fit = _fit_run(raw[(a + np.arange(span + 1)) % len(raw)], force=True) or ("line", [])
            fits.append((a, b, fit[0], fit[1]))
    else:
        corners_raw = _corner_vertices(raw, [])
        fits = _fit_edges(raw, corners_raw)
    fits.sort(key=lambda f: f[0])                 # edges in outline order from vertex 0
    n = len(raw)
    new_index = np.empty(n, dtype=int)
    pts: list[np.ndarray] = []
    for i in range(n):
        new_index[i] = len(pts)
        a, b = raw[i], raw[(i + 1) % n]
        seg = float(np.linalg.norm(b - a))
        m = max(1, math.ceil(seg / SAMPLE_SPACING_CM - 1e-9)) if seg > SPLIT_ABOVE_CM else 1
        for j in range(m):
            pts.append(a + (b - a) * (j / m))
    outline = np.array(pts)
    edges = []
    for k, (s, e, kind, ctrl) in enumerate(fits):
        edge = Edge(id=k, start=int(new_index[s]), end=int(new_index[e]), kind=kind,
                    p0=(float(raw[s, 0]), float(raw[s, 1])), p1=(float(raw[e, 0]), float(raw[e, 1])),
                    ctrl=list(ctrl))
        if kind != "line":
            edge.extra["_has_ctrl"] = True
        from . import curves
        edge.length_cm = round(curves.length(edge), 4)
        edges.append(edge)
    nodes = [e.start for e in edges]
    corners = sorted(int(new_index[c]) for c in corners_raw)
    return outline, edges, nodes, corners, new_index


def _piece_texts(texts: list[tuple[str, tuple[float, float], float, str]], block: str) -> dict[str, Any]:
    info: dict[str, Any] = {}
    free = []
    for text, at, height, layer in texts:
        key, val = _text_field(text)
        if key and key not in info:
            info[key] = val
            continue
        m = re.match(r"\s*(.+?),\s*cut\s+(\d+)\s*$", text, re.IGNORECASE)   # Valentina: 'Fabric, Cut 2'
        if m and "material" not in info:
            info["material"] = m.group(1)
            info.setdefault("quantity", m.group(2))
        free.append({"text": text, "at_cm": [at[0], at[1]], "height_cm": height, "layer": layer})
    info["annotations"] = free
    return info


def _panel(piece: _Piece, k: int, scale: float, unit: str, unit_from: str, path: Path,
           notes: list[str]) -> Panel:
    where = f"{path}: piece {k + 1} (block {piece.block!r})"
    by_layer: dict[str, list] = {}
    texts = []
    points: dict[str, list[np.ndarray]] = {}
    for e in piece.entities:
        layer = str(e.dxf.get("layer", "0"))
        t = e.dxftype()
        if t in ("TEXT", "MTEXT", "ATTRIB", "ATTDEF"):
            if t == "ATTDEF":
                continue
            at = _xy(e.dxf.get("insert", (0.0, 0.0, 0.0)))
            if piece.matrix is not None:
                at = _xy(piece.matrix.transform((at[0], at[1], 0.0)))
            text = _plain_text(e)
            if text:
                texts.append((text, (at[0] * scale, at[1] * scale),
                              _text_height(e, scale), layer))
            continue
        if t == "POINT":
            p = np.array(_xy(e.dxf.location))
            if piece.matrix is not None:
                p = np.array(_xy(piece.matrix.transform((p[0], p[1], 0.0))))
            points.setdefault(layer, []).append(p * scale)
            continue
        if t == "CIRCLE" and layer == "13":
            c = np.array(_xy(e.dxf.center))
            if piece.matrix is not None:
                c = np.array(_xy(piece.matrix.transform((c[0], c[1], 0.0))))
            points.setdefault("13", []).append(c * scale)
            continue
        if layer in _QUALITY_LAYERS:
            continue
        by_layer.setdefault(layer, []).extend(_entity_points(e, piece.matrix, scale))
    info = _piece_texts(texts, piece.block)
    name = info.get("name") or piece.block or f"piece {k + 1}"
    where = f"{path}: piece {name!r}" + (f" (size {info['size']})" if info.get("size") else "")
    boundary = [(p, c) for p, c in _chain(by_layer.get("1", [])) if len(p) >= 3]
    if not boundary:
        raise PatternError(f"{where}: no boundary (a closed polyline on layer 1)")
    boundary.sort(key=lambda pc: -abs(_area(pc[0])) if pc[1] else 0.0)
    cut, cut_closed = boundary[0]
    if not cut_closed:
        gap = float(np.linalg.norm(cut[-1] - cut[0])) * 10.0
        raise PatternError(f"{where}: the boundary on layer 1 is not closed (its ends are {gap:.3g} mm apart)")
    # the seam line: the sew line (layer 14), or Valentina's AAMA one on layer 8 (a closed line
    # holding most of the boundary's area); without one the boundary is the seam line
    internal = _chain(by_layer.get("8", []))
    sew_cands = [(p, c) for p, c in _chain(by_layer.get("14", [])) if c and len(p) >= 3]
    if not sew_cands:
        big = [(p, c) for p, c in internal if c and len(p) >= 3 and abs(_area(p)) > 0.5 * abs(_area(cut))]
        if not big and _extent(cut) > PIECE_MAX_CM:
            # a broken cut line (exports have points kilometres off): the largest closed
            # internal line of a plausible size is the seam line
            big = [(p, c) for p, c in internal if c and len(p) >= 3 and PIECE_MIN_CM <= _extent(p) <= PIECE_MAX_CM]
        if big:
            sew_cands = [max(big, key=lambda pc: abs(_area(pc[0])))]
            internal = [pc for pc in internal if pc[0] is not sew_cands[0][0]]
    seam = max(sew_cands, key=lambda pc: abs(_area(pc[0])))[0] if sew_cands else cut
    if seam is not cut and abs(_area(seam)) < 0.5 * abs(_area(cut)) and _extent(cut) <= PIECE_MAX_CM:
        notes.append(f"{where}: the sew line encloses only {abs(_area(seam)) / abs(_area(cut)):.0%} of the "
                     "cut line's area; kept as the seam line")
    _check_extent(seam, where, unit, unit_from)
    insert = np.array(piece.insert) * scale
    if float(np.abs(seam).max()) > FAR_CM:
        # a piece drawn far from the origin (exports place pieces kilometres off): its own
        # coordinates start at the origin, the offset goes to its place on the marker
        shift = np.floor(seam.min(axis=0))
        insert = insert + shift
        seam, cut = seam - shift, cut - shift
        internal = [(p - shift, c) for p, c in internal]
        by_layer = {ly: [(p - shift, c) for p, c in parts] for ly, parts in by_layer.items()}
        points = {ly: [p - shift for p in ps] for ly, ps in points.items()}
        info["annotations"] = [{**t, "at_cm": [t["at_cm"][0] - shift[0], t["at_cm"][1] - shift[1]]}
                               for t in info.get("annotations", [])]
        notes.append(f"{where}: drawn {float(np.abs(seam + shift).max()) / 100:.4g} m from the origin; "
                     f"moved to it, the offset ({shift[0]:g}, {shift[1]:g}) cm kept as its place on the marker")
    cut_line = None
    if seam is not cut:
        d, _, _ = _dist_to_polyline(cut, seam)
        if float(d.max()) > CUT_LINE_MAX_ALLOWANCE_CM:
            notes.append(f"{where}: the cut line (layer 1) reaches {float(d.max()) / 100:.4g} m from the "
                         "seam line; ignored, the seam line is kept")
        else:
            cut_line = cut
    if abs(_area(seam)) <= 0.0:
        raise PatternError(f"{where}: the seam line encloses no area")

    # notches: a LINE (or POINT) on layer 4 / 80-83 touching the seam or the cut line
    notch_specs = []
    for layer, ntype in _NOTCH_TYPES.items():
        for pts, _ in by_layer.get(layer, []):
            notch_specs.append((pts, ntype))
        for p in points.get(layer, []):
            notch_specs.append((p[None, :], ntype))
    raw = seam.copy()
    notch_at: list[tuple[int, float, float | None, str]] = []   # raw vertex, depth, angle, type
    for pts, ntype in notch_specs:
        ends = pts[[0, -1]]
        lines = [seam] + ([cut_line] if cut_line is not None else [])
        best = None
        for li, line in enumerate(lines):
            d, seg, frac = _dist_to_polyline(ends, line)
            j = int(np.argmin(d))
            if best is None or d[j] < best[0]:
                best = (float(d[j]), li, j, int(seg[j]), float(frac[j]))
        dist, li, j, seg, frac = best
        if dist > NOTCH_ON_LINE_CM:
            raise PatternError(f"{where}: a notch (layer 4) at ({ends[0][0]:.1f}, {ends[0][1]:.1f}) cm "
                               f"is {dist * 10:.1f} mm from the piece's outline")
        base = ends[j]
        tip = pts[-1] if j == 0 else pts[0]
        q = None
        if li == 1 and len(pts) > 1:
            # cut into the cutting line: where the notch, carried on, meets the seam line
            q = _ray_hit(base, (tip - base) / max(float(np.linalg.norm(tip - base)), 1e-12), raw)
        if q is None:
            _, seg_a, frac_a = _dist_to_polyline(base[None, :], raw)
            seg, frac = int(seg_a[0]), float(frac_a[0])
            q = raw[seg] + frac * (raw[(seg + 1) % len(raw)] - raw[seg])
        else:
            _, seg_a, _ = _dist_to_polyline(q[None, :], raw)
            seg = int(seg_a[0])
        a, b = raw[seg], raw[(seg + 1) % len(raw)]
        if np.linalg.norm(q - a) <= 1e-3:
            vi = seg
        elif np.linalg.norm(q - b) <= 1e-3:
            vi = (seg + 1) % len(raw)
        else:
            raw = np.insert(raw, seg + 1, q, axis=0)
            vi = seg + 1
            notch_at = [(v + (v > seg), dp, an, ty) for v, dp, an, ty in notch_at]
        depth = float(np.linalg.norm(pts[-1] - pts[0])) if len(pts) > 1 else None
        angle = None
        if len(pts) > 1:
            # against the outline's direction at the notch (as the writer measures it)
            dv = tip - base
            tang = raw[(vi + 1) % len(raw)] - raw[vi - 1]
            angle = round(math.degrees(math.atan2(tang[0] * dv[1] - tang[1] * dv[0], float(tang @ dv))), 6)
        notch_at.append((vi, depth or DEFAULT_NOTCH_DEPTH_CM, angle, ntype))

    hints: dict[str, list[int]] = {"2": [], "3": []}
    for layer in hints:
        for p in points.get(layer, []):
            d = np.linalg.norm(raw - p, axis=1)
            if float(d.min()) <= 0.001:
                hints[layer].append(int(np.argmin(d)))
    outline, edges, nodes, corners, new_index = build_panel_geometry(raw, hints["2"], hints["3"])
    from ..limits import OUTLINE_VERTICES
    OUTLINE_VERTICES.check(len(outline), where, error=PatternError)

    extra: dict[str, Any] = {}
    landmarks = {f"corner_{j}": int(c) for j, c in enumerate(corners)}
    if notch_at:
        extra["notches"] = []
        for j, (vi, depth, angle, ntype) in enumerate(notch_at):
            entry = {"vertex": int(new_index[vi]), "type": ntype, "depth_cm": round(depth, 6)}
            if angle is not None:
                entry["angle_deg"] = angle
            extra["notches"].append(entry)
            landmarks[f"notch_{j}"] = int(new_index[vi])
    grain = [pts for pts, _ in by_layer.get("7", [])]
    if grain:
        g = max(grain, key=lambda p: float(np.linalg.norm(p[-1] - p[0])))
        extra["grain_line_cm"] = [[float(g[0][0]), float(g[0][1])], [float(g[-1][0]), float(g[-1][1])]]
    if internal:
        extra["internal_lines"] = [{"points_cm": p.tolist(), "closed": bool(c)} for p, c in internal]
    cutouts = [p for p, c in _chain(by_layer.get("11", []))]
    if cutouts:
        extra["cutouts"] = [p.tolist() for p in cutouts]
    if points.get("13"):
        extra["drill_holes_cm"] = [[float(p[0]), float(p[1])] for p in points["13"]]
    for key in ("size", "category", "quantity", "material"):
        if info.get(key):
            extra[key] = info[key]
    dxf: dict[str, Any] = {"block": piece.block}
    if np.any(insert != 0.0):
        dxf["insert_cm"] = [float(insert[0]), float(insert[1])]
    if info.get("annotations"):
        dxf["texts"] = info["annotations"]
    if cut_line is not None:
        dxf["cut_line_cm"] = cut_line.tolist()
        dxf["seam_line_sha1"] = outline_digest(outline)
        _measure_allowance(outline, edges, cut_line)
    extra["dxf"] = dxf

    placement = Placement(kind="hint", rotation=np.eye(3), translation_m=np.zeros(3))
    return Panel(name=name, outline_cm=outline, orientation="ccw" if _area(outline) > 0 else "cw",
                 nodes=nodes, corners=corners, landmarks=landmarks, edges=edges, placement=placement,
                 extra=extra)


def _extent(pts: np.ndarray) -> float:
    return float(np.max(pts.max(axis=0) - pts.min(axis=0)))


def _check_extent(seam: np.ndarray, where: str, unit: str, unit_from: str) -> None:
    ext = _extent(seam)
    if not (PIECE_MIN_CM <= ext <= PIECE_MAX_CM):
        size = f"{ext:.3g} cm" if ext < 100 else f"{ext / 100:.3g} m"
        raise PatternError(f"{where}: is {size} across with units {unit} (from {unit_from}), not a plausible "
                           f"pattern piece ({PIECE_MIN_CM:g} cm to {PIECE_MAX_CM / 100:g} m); give the units "
                           "with --dxf-units")


def outline_digest(outline: np.ndarray) -> str:
    """A fingerprint of an outline at 1e-6 cm: tells whether the seam line changed since reading."""
    q = np.round(np.asarray(outline, dtype=float) * 1e6).astype(np.int64)
    return hashlib.sha1(q.tobytes()).hexdigest()


def _measure_allowance(outline: np.ndarray, edges: list[Edge], cut: np.ndarray) -> None:
    """Each edge's seam allowance: the median distance from its outline points to the cut line."""
    d, _, _ = _dist_to_polyline(outline, cut)
    n = len(outline)
    for e in edges:
        idx = (e.start + np.arange((e.end - e.start) % n + 1)) % n
        e.extra["seam_allowance_cm"] = round(float(np.median(d[idx])), 4)


# ============================================================================ writing

def flavor_from_path(path: str | Path) -> str | None:
    name = Path(path).name.lower()
    for f in FLAVORS:
        if name.endswith(f".{f}.dxf"):
            return f
    return None


def write_dxf(pattern: Pattern, path: str | Path, *, flavor: str = "aama", units: str = "mm",
              seam_allowance_cm: float | None = None, corners: str = "mitre") -> Path:
    """Write ``pattern`` as a DXF-AAMA or DXF-ASTM file, atomically.

    Every panel becomes a block (seam line, cut line when the pattern has a seam allowance,
    turn points, notches, grain line, internal lines, cutouts, drill holes, piece texts)
    inserted once in model space. The cut line read from a DXF is written back as it was
    while the seam line is unchanged; otherwise it is rebuilt from the per-edge allowances
    (``seam_allowance_cm`` on the edges, measured when the DXF was read), or from
    ``seam_allowance_cm`` here for edges without one; ``corners`` 'mitre' or 'square'.
    """
    doc = build_dxf(pattern, flavor=flavor, units=units, seam_allowance_cm=seam_allowance_cm,
                    corners=corners, name=Path(path).name)
    import io
    buf = io.StringIO()
    doc.write(buf)
    # characters outside the code page as \\U+XXXX, which DXF readers decode
    return atomic_write_bytes(Path(path), buf.getvalue().encode(doc.output_encoding, errors="dxfreplace"))


def build_dxf(pattern: Pattern, *, flavor: str = "aama", units: str = "mm",
              seam_allowance_cm: float | None = None, corners: str = "mitre", name: str = "pattern"):
    """The ezdxf document :func:`write_dxf` writes."""
    import ezdxf
    from .allowance import cut_line
    if flavor not in FLAVORS:
        raise PatternError(f"{name}: unknown DXF flavour {flavor!r} (expected aama or astm)")
    if units not in ("mm", "in"):
        raise PatternError(f"{name}: DXF units must be mm or in, not {units!r}")
    if seam_allowance_cm is not None and not (math.isfinite(seam_allowance_cm) and seam_allowance_cm >= 0):
        raise PatternError(f"{name}: seam allowance {seam_allowance_cm!r} cm must be a finite number >= 0")
    k = 1.0 / UNITS_CM[units]                  # cm -> drawing units
    doc = ezdxf.new("R2000", setup=False)
    doc.header["$INSUNITS"] = _UNITS_CODE[units]
    doc.header["$MEASUREMENT"] = 1 if units == "mm" else 0
    doc.header["$DWGCODEPAGE"] = "ANSI_1252"
    for layer in ("1", "2", "3", "4", "7", "8", "11", "13", "14", "15", "80", "81", "82", "83", "84", "85", "86", "87"):
        if flavor == "aama" and layer in _QUALITY_LAYERS | {"15"}:
            continue
        doc.layers.add(layer)
    msp = doc.modelspace()
    header = dict((pattern.extra.get("dxf") or {}).get("header") or {})
    style = pattern.extra.get("style_name") or header.get("style") or pattern.garment_id
    lines = []
    if style:
        lines.append(f"Style Name: {style}")
    for key, label in (("creation_date", "Creation Date"), ("author", "Author"), ("sample_size", "Sample Size")):
        if header.get(key):
            lines.append(f"{label}: {header[key]}")
    lines.append(f"Units: {'METRIC' if units == 'mm' else 'ENGLISH'}")
    text_h = 0.5 * k
    for j, line in enumerate(lines):
        msp.add_text(line, height=text_h, dxfattribs={"layer": "1", "insert": (0.0, -(j + 1) * 1.5 * text_h)})

    used: set[str] = set()
    x_cursor = 0.0
    for panel in pattern.panels:
        o = np.asarray(panel.outline_cm, dtype=float)
        if not np.all(np.isfinite(o)):
            raise PatternError(f"{name}: panel {panel.name!r} has a non-finite outline point; not written")
        dxf = panel.extra.get("dxf") if isinstance(panel.extra.get("dxf"), dict) else {}
        block = _block_name(str(dxf.get("block") or panel.name), used)
        blk = doc.blocks.new(block)
        cut = None
        if dxf.get("cut_line_cm") and dxf.get("seam_line_sha1") == outline_digest(o) and seam_allowance_cm is None:
            cut = np.asarray(dxf["cut_line_cm"], dtype=float)
        elif seam_allowance_cm is not None or any("seam_allowance_cm" in e.extra for e in panel.edges):
            cut = cut_line(panel, seam_allowance_cm, corners)
        boundary = cut if cut is not None else o
        _poly(blk, boundary, k, "1", flavor, "84")
        if cut is not None:
            _poly(blk, o, k, "14", flavor, "87")
        # turn points (corners) and curve points (the other ends of edges): a reader of this
        # file gets the same edges back
        for c in sorted(set(panel.corners) | set(panel.nodes)):
            if 0 <= c < len(o):
                blk.add_point((o[c, 0] * k, o[c, 1] * k), dxfattribs={"layer": "2" if c in panel.corners else "3"})
        _notches(blk, panel, o, cut, k)
        g = panel.extra.get("grain_line_cm")
        if g:
            blk.add_line(tuple(np.multiply(g[0], k)), tuple(np.multiply(g[1], k)), dxfattribs={"layer": "7"})
        for line in panel.extra.get("internal_lines") or []:
            _poly(blk, np.asarray(line["points_cm"], dtype=float), k, "8", flavor, "85",
                  closed=bool(line.get("closed")))
        for cutout in panel.extra.get("cutouts") or []:
            _poly(blk, np.asarray(cutout, dtype=float), k, "11", flavor, "86")
        for p in panel.extra.get("drill_holes_cm") or []:
            blk.add_point((p[0] * k, p[1] * k), dxfattribs={"layer": "13"})
        _piece_text(blk, panel, o, k, flavor)
        ins = dxf.get("insert_cm") or ([0.0, 0.0] if "block" in dxf else None)
        if ins is None:                            # not from a DXF: pieces left to right, 5 cm apart
            lo, hi = o.min(axis=0), o.max(axis=0)
            ins = [x_cursor - lo[0], -lo[1]]
            x_cursor += float(hi[0] - lo[0]) + 5.0
        msp.add_blockref(block, (ins[0] * k, ins[1] * k), dxfattribs={"layer": "1"})
    return doc


def _cp1252(text: str) -> str:
    return str(text).encode("cp1252", errors="replace").decode("cp1252")


def _block_name(name: str, used: set[str]) -> str:
    from ezdxf.lldxf.validator import is_valid_block_name
    base = re.sub(r'[<>/\\":;?*|=`]', "_", _cp1252(name)).strip() or "piece"
    if not is_valid_block_name(base):
        base = "piece"
    out, j = base, 2
    while out.lower() in used:
        out = f"{base} {j}"
        j += 1
    used.add(out.lower())
    return out


def _poly(blk, pts: np.ndarray, k: float, layer: str, flavor: str, quality: str, closed: bool = True) -> None:
    xy = [(float(u) * k, float(v) * k) for u, v in pts]
    blk.add_lwpolyline(xy, close=closed, dxfattribs={"layer": layer})
    if flavor == "astm":                       # ASTM: the quality-validation copy
        blk.add_lwpolyline(xy, close=closed, dxfattribs={"layer": quality})


def _notches(blk, panel: Panel, o: np.ndarray, cut: np.ndarray | None, k: float) -> None:
    n = len(o)
    for notch in panel.extra.get("notches") or []:
        i = int(notch.get("vertex", -1))
        if not 0 <= i < n:
            continue
        tang = o[(i + 1) % n] - o[i - 1]
        tang = tang / max(float(np.linalg.norm(tang)), 1e-12)
        inward = np.array([-tang[1], tang[0]]) * (1.0 if _area(o) > 0 else -1.0)
        depth = float(notch.get("depth_cm") or DEFAULT_NOTCH_DEPTH_CM)
        ang = notch.get("angle_deg")
        if ang is not None:
            a = math.radians(float(ang))
            direc = np.array([tang[0] * math.cos(a) - tang[1] * math.sin(a), tang[0] * math.sin(a) + tang[1] * math.cos(a)])
        else:
            direc = inward
        base = o[i]
        if cut is not None:                    # cut into the cutting line, in line with the seam vertex
            hit = _ray_hit(o[i], -direc, cut)
            back = _ray_hit(o[i] - 1e-6 * direc, -direc, o)
            # not where the seam line itself comes first (inside a dart's opening)
            if hit is not None and (back is None or np.linalg.norm(back - o[i]) > np.linalg.norm(hit - o[i])):
                base = hit
        tip = base + depth * direc
        layer = {v: key for key, v in _NOTCH_TYPES.items()}.get(notch.get("type", "slit"), "4")
        # slits on layer 4, the other kinds on ASTM's notch-type layers 80-83
        blk.add_line((base[0] * k, base[1] * k), (tip[0] * k, tip[1] * k), dxfattribs={"layer": layer})


_RAY_T_EPS = 1e-9                # fraction of a segment: a crossing at a vertex counts on both sides


def _ray_hit(p: np.ndarray, d: np.ndarray, poly: np.ndarray) -> np.ndarray | None:
    """First crossing of the ray p + s d (s > 0) with a closed polyline, its vertices
    included: a notch's ray runs through the seam (or cut) line's vertex by construction,
    and rounding may put that crossing a hair past the end of both segments meeting there."""
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a
    den = d[0] * e[:, 1] - d[1] * e[:, 0]
    ok = np.abs(den) > 1e-12
    w = a - p
    s = np.where(ok, (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / np.where(ok, den, 1.0), np.inf)
    t = np.where(ok, (w[:, 0] * d[1] - w[:, 1] * d[0]) / np.where(ok, den, 1.0), -1.0)
    good = ok & (s > 0) & (t >= -_RAY_T_EPS) & (t <= 1.0 + _RAY_T_EPS)
    if not np.any(good):
        return None
    j = int(np.argmin(np.where(good, s, np.inf)))
    return p + s[j] * d


def _piece_text(blk, panel: Panel, o: np.ndarray, k: float, flavor: str) -> None:
    dxf = panel.extra.get("dxf") if isinstance(panel.extra.get("dxf"), dict) else {}
    lo, hi = o.min(axis=0), o.max(axis=0)
    h = max(0.4, min(1.5, 0.03 * float(min(hi - lo))))
    at = np.array([0.5 * (lo[0] + hi[0]) - 3 * h, 0.5 * (lo[1] + hi[1])])
    lines = [f"Piece Name: {panel.name}"]
    for key, label in (("size", "Size"), ("category", "Category"), ("quantity", "Quantity"),
                       ("material", "Material")):
        if panel.extra.get(key):
            lines.append(f"{label}: {panel.extra[key]}")
    for j, line in enumerate(lines):
        blk.add_text(line, height=h * k, dxfattribs={"layer": "1", "insert": (at[0] * k, (at[1] - 1.5 * j * h) * k)})
    for t in dxf.get("texts") or []:
        try:
            x, y = (float(c) for c in t["at_cm"])
            height = float(t.get("height_cm") or h)
            text = str(t["text"])
        except (KeyError, TypeError, ValueError):
            continue
        if _text_field(text)[0] is not None:
            continue                               # written above from the panel's fields
        layer = str(t.get("layer") or "1")
        if layer == "15" and flavor == "aama":
            continue
        blk.add_text(text, height=height * k, dxfattribs={"layer": layer, "insert": (x * k, y * k)})
    if flavor == "astm" and not any(str(t.get("layer")) == "15" for t in dxf.get("texts") or []):
        blk.add_text(panel.name, height=h * k,
                     dxfattribs={"layer": "15", "insert": (at[0] * k, (at[1] + 1.5 * h) * k)})

