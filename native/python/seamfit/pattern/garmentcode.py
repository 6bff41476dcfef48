"""Import GarmentCode (pygarment) ``*_specification.json`` patterns.

GarmentCode stores each panel as a vertex list plus edges between vertex ids, with a
``curvature`` description per curved edge, a 3D placement (translation in cm and Euler
XYZ rotation in degrees, Y up, body facing +Z) and edge-to-edge stitches. This module
turns that into the same :class:`~seamfit.pattern.model.Pattern` a ``sewpat-1`` file
gives: outline samples at <= 1 cm along each edge, nodes, corners, ``gc_v<k>``
landmarks, explicit Bezier/arc edges, placement in seamfit's world frame, and stitches
with orientation and ``gathered`` flags. See docs/formats.md for what is not mapped.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import PatternError
from . import curves
from .json_file import read_json
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide
from .validate import find_self_intersections

SAMPLE_SPACING_CM = 1.0
CORNER_ANGLE_DEG = 12.0        # a node is a corner where the tangent turns by more than this
GATHER_THRESHOLD_CM = 0.5      # stitch sides differing by more than this are gathered / eased

# GarmentCode world (cm, Y up, body faces +Z) -> seamfit world (m, Z up, body faces -Y):
# p = [x, -z, y] / 100.
GC_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

_SPEC_SUFFIX = "_specification"


def is_garmentcode_spec(d: Any) -> bool:
    """True for a parsed JSON document shaped like a GarmentCode specification."""
    return (isinstance(d, dict) and isinstance(d.get("pattern"), dict)
            and isinstance(d["pattern"].get("panels"), dict))


def read_garmentcode(path: str | Path) -> Pattern:
    """Read a GarmentCode ``*_specification.json`` file."""
    path = Path(path)
    d = read_json(path, "GarmentCode")
    return pattern_from_garmentcode(d, str(path), garment_id=garment_id_from_path(path))


def garment_id_from_path(path: str | Path) -> str | None:
    """``gc_pencil_skirt`` for ``.../gc_pencil_skirt_specification.json``."""
    stem = Path(path).stem
    return (stem[:-len(_SPEC_SUFFIX)] if stem.endswith(_SPEC_SUFFIX) else stem) or None


def euler_xyz_deg_to_matrix(euler_deg) -> np.ndarray:
    """GarmentCode's rotation: Euler XYZ angles in degrees, R = Rz @ Ry @ Rx."""
    x, y, z = np.deg2rad(np.asarray(euler_deg, dtype=float))
    cx, sx, cy, sy, cz, sz = np.cos(x), np.sin(x), np.cos(y), np.sin(y), np.cos(z), np.sin(z)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def matrix_to_quat_xyzw(r: np.ndarray) -> list[float]:
    """Unit quaternion [x, y, z, w] (w >= 0) of a rotation matrix."""
    m = np.asarray(r, dtype=float)
    # the largest of the four squared components is computed without cancellation
    tr = np.trace(m)
    cand = [tr, m[0, 0], m[1, 1], m[2, 2]]
    k = int(np.argmax(cand))
    if k == 0:
        w = 0.5 * math.sqrt(max(1.0 + tr, 0.0))
        q = [(m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w), w]
    else:
        i = k - 1
        j, l = (i + 1) % 3, (i + 2) % 3
        s = 0.5 * math.sqrt(max(1.0 + m[i, i] - m[j, j] - m[l, l], 0.0))
        q = [0.0, 0.0, 0.0, (m[l, j] - m[j, l]) / (4 * s)]
        q[i] = s
        q[j] = (m[j, i] + m[i, j]) / (4 * s)
        q[l] = (m[l, i] + m[i, l]) / (4 * s)
    q = np.asarray(q)
    if q[3] < 0:
        q = -q
    return [float(c) for c in q / np.linalg.norm(q)]


def _num_list(v, n: int, where: str) -> list[float]:
    try:
        out = [float(c) for c in v]
    except (TypeError, ValueError) as exc:
        raise PatternError(f"{where}: expected {n} numbers, got {v!r}") from exc
    if len(out) != n or not all(math.isfinite(c) for c in out):
        raise PatternError(f"{where}: expected {n} finite numbers, got {v!r}")
    return out


def _rel_to_abs(p0: np.ndarray, p1: np.ndarray, rel, where: str) -> tuple[float, float]:
    # GarmentCode's relative control point: x along the chord (0 at start, 1 at end),
    # y along the chord turned +90 deg, both in units of the chord length.
    x, y = _num_list(rel, 2, where)
    chord = p1 - p0
    q = p0 + x * chord + y * np.array([-chord[1], chord[0]])
    return float(q[0]), float(q[1])


def _circle_arc(p0: np.ndarray, p1: np.ndarray, radius: float, large_arc: bool, right: bool,
                where: str) -> dict:
    """Centre and angles of GarmentCode's circle edge (SVG-like): the arc of the given
    radius from p0 to p1 that bulges to the right of the chord when ``right`` (i.e. runs
    counter-clockwise), spanning more than half a circle when ``large_arc``."""
    chord = p1 - p0
    c = float(np.linalg.norm(chord))
    if c == 0.0 or not radius > 0:
        raise PatternError(f"{where}: circle edge needs distinct end points and a positive radius "
                           f"(chord {c:.6g} cm, radius {radius!r})")
    half = 0.5 * c
    if radius < half:
        # GarmentCode rounds radii; a radius a hair short of half the chord is a half circle
        if radius < half * (1.0 - 1e-6):
            raise PatternError(f"{where}: circle radius {radius:.6g} cm is shorter than half the "
                               f"chord ({half:.6g} cm)")
        radius = half
    d = math.sqrt(max(radius * radius - half * half, 0.0))
    left = np.array([-chord[1], chord[0]]) / c
    ccw = bool(right)
    # centre left of the chord for a small ccw arc or a large cw one
    center = 0.5 * (p0 + p1) + (d if ccw != bool(large_arc) else -d) * left
    a0 = math.atan2(p0[1] - center[1], p0[0] - center[0])
    a1 = math.atan2(p1[1] - center[1], p1[0] - center[0])
    sweep = (a1 - a0) % (2 * math.pi) if ccw else -((a0 - a1) % (2 * math.pi))
    return {"center": [float(center[0]), float(center[1])], "radius": float(radius),
            "angle0_rad": a0, "angle1_rad": a0 + sweep}


def _edge_curve(e: dict, verts: np.ndarray, scale: float, absolute: bool, where: str) -> Edge:
    ends = e.get("endpoints")
    if not (isinstance(ends, list) and len(ends) == 2 and all(isinstance(i, int) for i in ends)):
        raise PatternError(f"{where}: 'endpoints' must be two vertex ids, got {ends!r}")
    for i in ends:
        if not 0 <= i < len(verts):
            raise PatternError(f"{where}: endpoint vertex {i} does not exist "
                               f"(the panel has {len(verts)} vertices)")
    p0, p1 = verts[ends[0]], verts[ends[1]]
    edge = Edge(id=-1, start=-1, end=-1, kind="line", p0=(float(p0[0]), float(p0[1])),
                p1=(float(p1[0]), float(p1[1])), label=e.get("label"))
    cv = e.get("curvature")
    if cv is None:
        return edge
    if isinstance(cv, list):                      # older files: one quadratic control point
        cv = {"type": "quadratic", "params": [cv]}
    if not isinstance(cv, dict):
        raise PatternError(f"{where}: unreadable curvature {cv!r}")
    kind, params = cv.get("type"), cv.get("params")
    if kind in ("quadratic", "cubic"):
        need = 1 if kind == "quadratic" else 2
        if not (isinstance(params, list) and len(params) == need):
            raise PatternError(f"{where}: {kind} curvature needs {need} control point(s), got {params!r}")
        if absolute:
            edge.ctrl = [tuple(scale * c for c in _num_list(q, 2, where)) for q in params]
        else:
            edge.ctrl = [_rel_to_abs(p0, p1, q, where) for q in params]
        edge.kind = kind
    elif kind == "circle":
        if not (isinstance(params, list) and len(params) == 3):
            raise PatternError(f"{where}: circle curvature needs [radius, large_arc, right], got {params!r}")
        radius, large_arc, right = _num_list(params, 3, where)
        edge.kind = "arc"
        edge.arc = _circle_arc(p0, p1, scale * radius, bool(large_arc), bool(right), where)
    else:
        raise PatternError(f"{where}: unsupported curvature type {kind!r} "
                           "(seamfit reads quadratic, cubic and circle)")
    return edge


def _turn_deg(a: np.ndarray, b: np.ndarray) -> float:
    if not (np.any(a) and np.any(b)):
        return 180.0                              # a zero-length curve has no tangent: keep the corner
    return math.degrees(math.atan2(abs(a[0] * b[1] - a[1] * b[0]), float(a @ b)))


def _panel(name: str, d: Any, scale: float, absolute: bool, where: str,
           samples_so_far: int = 0) -> tuple[Panel, list[int]]:
    if not isinstance(d, dict):
        raise PatternError(f"{where}: a panel is a JSON object")
    try:
        verts = scale * np.asarray(d.get("vertices"), dtype=float)
    except (TypeError, ValueError) as exc:
        raise PatternError(f"{where}: 'vertices' must be a list of [x, y] points") from exc
    if verts.ndim != 2 or verts.shape[1] != 2 or len(verts) < 2 or not np.all(np.isfinite(verts)):
        raise PatternError(f"{where}: 'vertices' must be a list of at least 2 finite [x, y] points")
    raw_edges = d.get("edges")
    if not isinstance(raw_edges, list) or not raw_edges:
        raise PatternError(f"{where}: 'edges' must be a non-empty list")

    edges: list[Edge] = []
    vertex_ids: list[int] = []
    for k, e in enumerate(raw_edges):
        ew = f"{where} edge {k}"
        if not isinstance(e, dict):
            raise PatternError(f"{ew}: an edge is a JSON object")
        edge = _edge_curve(e, verts, scale, absolute, ew)
        ends = e["endpoints"]
        # seamfit's outline is the edge loop in file order; GarmentCode writes loops so
        prev_end = raw_edges[k - 1].get("endpoints", [None, None])[1] if k else None
        if k and ends[0] != prev_end:
            raise PatternError(f"{ew}: starts at vertex {ends[0]} but edge {k - 1} ends at vertex "
                               f"{prev_end}; the edges must form one loop in order")
        edge.id = k
        edge.extra["source_ref"] = {"gc_edge": k, "gc_endpoints": [int(ends[0]), int(ends[1])]}
        edges.append(edge)
        vertex_ids.append(int(ends[0]))
    last_end = raw_edges[-1]["endpoints"][1]
    if last_end != raw_edges[0]["endpoints"][0]:
        raise PatternError(f"{where} edge {len(raw_edges) - 1}: ends at vertex {last_end}, not at the "
                           f"loop's first vertex {raw_edges[0]['endpoints'][0]}; the outline is open")

    # Count the samples before taking them: one far vertex makes kilometres of outline.
    from ..limits import OUTLINE_VERTICES
    expect = sum(max(1, math.ceil(curves.length(e) / SAMPLE_SPACING_CM)) for e in edges)
    if not math.isfinite(expect):
        raise PatternError(f"{where}: an edge has no finite length")
    OUTLINE_VERTICES.check(samples_so_far + expect, where,
                           f"its edges sampled every {SAMPLE_SPACING_CM:g} cm make {expect:,} outline vertices"
                           + (f" ({samples_so_far + expect:,} with the panels before it)" if samples_so_far else ""),
                           PatternError)
    pieces, nodes = [], []
    start = 0
    for edge in edges:
        pts = curves.sample_by_length(edge, SAMPLE_SPACING_CM)
        edge.length_cm = round(curves.length(edge), 4)
        nodes.append(start)
        edge.start = start
        pieces.append(pts[:-1])
        start += len(pts) - 1
    outline = np.concatenate(pieces)
    if len(outline) < 3:
        raise PatternError(f"{where}: the outline has only {len(outline)} samples")
    for k, edge in enumerate(edges):
        edge.end = edges[(k + 1) % len(edges)].start

    tangents = [curves.end_tangents(e) for e in edges]
    corners = [nodes[k] for k in range(len(edges))
               if _turn_deg(tangents[k - 1][1], tangents[k][0]) > CORNER_ANGLE_DEG]
    landmarks: dict[str, int] = {}
    for k, vid in enumerate(vertex_ids):
        landmarks.setdefault(f"gc_v{vid}", nodes[k])

    translation = _num_list(d.get("translation", [0, 0, 0]), 3, where + " translation")
    rotation = _num_list(d.get("rotation", [0, 0, 0]), 3, where + " rotation")
    r_world = GC_TO_WORLD @ euler_xyz_deg_to_matrix(rotation)
    t_world = GC_TO_WORLD @ (scale * np.asarray(translation)) / 100.0
    side = "front" if translation[2] > 0 else "back" if translation[2] < 0 else None
    placement = Placement(
        kind="exact", rotation=r_world, translation_m=t_world, side=side,
        extra={"rotation_quat_xyzw": matrix_to_quat_xyzw(r_world),
               "source_translation_gc_cm": [scale * c for c in translation],
               "source_rotation_gc_euler_deg": rotation})

    u, v = outline[:, 0], outline[:, 1]
    signed = 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v))
    extra: dict[str, Any] = {}
    if "label" in d:
        extra["segment_label"] = d["label"]
    extra["self_intersections"] = len(find_self_intersections(outline))
    panel = Panel(name=name, outline_cm=outline, orientation="ccw" if signed > 0 else "cw",
                  nodes=nodes, corners=corners, landmarks=landmarks, edges=edges,
                  placement=placement, extra=extra)
    return panel, vertex_ids


def pattern_from_garmentcode(d: Any, source: str = "<garmentcode>", *,
                             garment_id: str | None = None) -> Pattern:
    """Convert a parsed GarmentCode specification (dict) into a Pattern."""
    if not is_garmentcode_spec(d):
        raise PatternError(f"{source}: not a GarmentCode specification (needs pattern.panels)")
    props = d.get("properties") or {}
    if not isinstance(props, dict):
        raise PatternError(f"{source}: properties must be a JSON object")
    try:
        units_in_meter = float(props.get("units_in_meter", 100))
    except (TypeError, ValueError) as exc:
        raise PatternError(f"{source}: properties.units_in_meter must be a number") from exc
    if not units_in_meter > 0:
        raise PatternError(f"{source}: properties.units_in_meter must be positive, got {units_in_meter}")
    scale = 100.0 / units_in_meter                       # file units -> cm
    coords = props.get("curvature_coords", "relative")
    if coords not in ("relative", "absolute"):
        raise PatternError(f"{source}: unknown properties.curvature_coords {coords!r}")

    from ..limits import PANELS
    spec = d["pattern"]
    raw_panels = spec["panels"]
    PANELS.check(len(raw_panels), source, error=PatternError)
    panel_order = spec.get("panel_order", [])
    if not isinstance(panel_order, list):
        raise PatternError(f"{source}: pattern.panel_order must be a list of panel names")
    order = [n for n in panel_order if isinstance(n, str) and n in raw_panels]
    order += [n for n in raw_panels if n not in order]
    panels, vertex_ids = [], {}
    samples = 0
    for name in order:
        panel, vids = _panel(str(name), raw_panels[name], scale, coords == "absolute",
                             f"{source}: panel {name!r}", samples)
        samples += len(panel.outline_cm)
        panels.append(panel)
        vertex_ids[panel.name] = vids
    by_name = {p.name: p for p in panels}

    stitches = []
    raw_stitches = spec.get("stitches", [])
    if not isinstance(raw_stitches, list):
        raise PatternError(f"{source}: pattern.stitches must be a list")
    for k, s in enumerate(raw_stitches):
        where = f"{source}: stitch {k}"
        if not (isinstance(s, list) and len(s) >= 2):
            raise PatternError(f"{where}: a stitch is a list of two {{panel, edge}} objects, got {s!r}")
        sides = []
        for tag, side in zip("ab", s[:2]):
            sw = f"{where} side {tag}"
            if not isinstance(side, dict):
                raise PatternError(f"{sw}: expected {{panel, edge}}, got {side!r}")
            pname, eid = side.get("panel"), side.get("edge")
            if pname not in by_name:
                raise PatternError(f"{sw}: unknown panel {pname!r}")
            panel = by_name[pname]
            if not isinstance(eid, int) or not 0 <= eid < len(panel.edges):
                raise PatternError(f"{sw}: panel {pname!r} has no edge {eid!r} "
                                   f"(it has {len(panel.edges)})")
            edge = panel.edges[eid]
            vids = vertex_ids[pname]
            sides.append(StitchSide(panel=pname, range=(edge.start, edge.end), edge=eid,
                                    landmarks=[f"gc_v{vids[eid]}", f"gc_v{vids[(eid + 1) % len(vids)]}"]))
        la = curves.length(by_name[sides[0].panel].edges[sides[0].edge])
        lb = curves.length(by_name[sides[1].panel].edges[sides[1].edge])
        extra = {"source_flags": list(s[2:])} if len(s) > 2 else {}
        # GarmentCode sews edges right sides together: a's start meets b's end
        stitches.append(Stitch(
            kind="dart_or_internal" if sides[0].panel == sides[1].panel else "seam",
            a=sides[0], b=sides[1], orientation="reversed",
            gathered=abs(la - lb) > GATHER_THRESHOLD_CM,
            length_a_cm=round(la, 4), length_b_cm=round(lb, 4), extra=extra))

    return Pattern(
        panels=panels, stitches=stitches, garment_id=garment_id, source_file=source,
        extra={"units": {"outline": "cm", "placement": "m"},
               "source": {"system": "GarmentCode", "native_files": [Path(source).name],
                          "properties": dict(props),
                          "notes": "imported by seamfit; placement not aligned to a body "
                                   "(no body_alignment_dy_m)"}})

