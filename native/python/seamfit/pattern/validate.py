"""Check a pattern before it reaches the mesher and the solver.

Every message names the file, then the panel (and outline vertex indices), edge or
stitch (index and kind) at fault, so a user can find it in the file. Tolerances and
their reasons are listed in docs/formats.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ValidationError
from .model import EDGE_KINDS, Panel, Pattern, StitchSide, range_indices
from .notches import notch_misses

# Non-gathered stitch sides may differ by max(SEAM_TOLERANCE_CM, SEAM_TOLERANCE_REL * longer
# side). Drafted patterns agree to < 0.6 cm (designed ease such as a shoulder seam's ~0.3 cm,
# plus sampling); 1 cm / 2 % is beyond that but far below the 2-3 cm a deliberate gather or
# a mistake produces, which the solver would otherwise have to force together.
SEAM_TOLERANCE_CM = 1.0
SEAM_TOLERANCE_REL = 0.02
# Points closer than this are the same point (outline samples are ~1 cm apart; files keep
# 1e-4 cm), so a "segment" shorter than this has no direction.
SAME_POINT_CM = 1e-6
# An edge's curve end points and its outline vertices may disagree by rounding only.
CURVE_OUTLINE_TOL_CM = 0.05
# Garment panels measure ~3 cm (narrow bands) to ~300 cm (a long full-circle skirt) across.
# A largest panel beyond 400 "cm" is a millimetre file, below 3 "cm" a metre file.
MM_EXTENT_CM = 400.0
M_EXTENT_CM = 3.0
ROTATION_TOL = 1e-4
# No garment point lies a kilometre from its panel's origin; beyond this, sums of
# coordinates overflow and the outline is a file error, not a shape.
MAX_COORD_CM = 1e5
_MAX_LISTED = 5


@dataclass
class ValidationReport:
    source: str
    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    fixable: list[str] = field(default_factory=list)   # warnings that fix_pattern() repairs

    @property
    def ok(self) -> bool:
        return not self.errors

    def __str__(self) -> str:
        lines = [f"{self.source}: {len(self.errors)} error(s), {len(self.warnings)} warning(s)"]
        lines += [f"error: {m}" for m in self.errors] + [f"warning: {m}" for m in self.warnings]
        return "\n".join(lines)


# ----------------------------------------------------------------------------- geometry

def _orient(p, q, r) -> np.ndarray:
    return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])


def _on_segment(p, q, r) -> np.ndarray:
    """r (known collinear with p-q) lies within the segment's bounding box."""
    return ((np.minimum(p[:, 0], q[:, 0]) <= r[:, 0]) & (r[:, 0] <= np.maximum(p[:, 0], q[:, 0]))
            & (np.minimum(p[:, 1], q[:, 1]) <= r[:, 1]) & (r[:, 1] <= np.maximum(p[:, 1], q[:, 1])))


def _candidate_pairs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairs (i < j) of segments whose bounding boxes share a cell of a uniform grid.

    Cells are about two segment lengths wide, so each segment falls in a few cells and
    the work is ~linear in the number of segments instead of quadratic.
    """
    m = len(a)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    origin = lo.min(axis=0)
    span = float(max((hi.max(axis=0) - origin).max(), 1e-12))
    # a finer floor than span / 1024 keeps a few segments per cell on long, finely sampled
    # outlines (100K vertices: 3 s with span / 1024, linear time with this)
    h = max(2.0 * float(np.median(np.linalg.norm(b - a, axis=1))), span / 65536.0)
    extra = []
    while True:
        i0 = np.floor((lo - origin) / h).astype(np.int64)
        i1 = np.floor((hi - origin) / h).astype(np.int64)
        w = i1 - i0 + 1
        count = w[:, 0] * w[:, 1]
        # the few segments that span many cells (a long straight hem drawn as one
        # segment) are paired with every segment whose box they overlap instead
        long = np.nonzero(count > 64)[0]
        if len(long) * m <= 4_000_000:
            break
        h *= 2.0                                        # many long segments: coarser grid
    for s in long:
        near = np.nonzero(np.all(lo <= hi[s], axis=1) & np.all(hi >= lo[s], axis=1))[0]
        extra.append(np.stack([np.full(len(near), s), near], axis=1))
    count[long] = 0
    seg = np.repeat(np.arange(m), count)
    local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    cx = i0[seg, 0] + local % w[seg, 0]
    cy = i0[seg, 1] + local // w[seg, 0]
    ny = int(i1[:, 1].max()) + 1
    cell = cx * ny + cy
    order = np.lexsort((seg, cell))
    cell, seg = cell[order], seg[order]
    pairs = extra
    d = 1
    while d < len(cell):
        same = cell[:-d] == cell[d:]
        if not same.any():
            break
        pairs.append(np.stack([seg[:-d][same], seg[d:][same]], axis=1))
        d += 1
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    p = np.concatenate(pairs)
    p.sort(axis=1)
    return np.unique(p[p[:, 0] != p[:, 1]], axis=0)


def find_self_intersections(outline: np.ndarray) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of outline segments (i, i+1) and (j, j+1) (indices wrap) that
    cross or touch without being neighbours. Zero-length segments are skipped (they are
    reported separately) so that a duplicated point is not a false crossing."""
    pts = np.asarray(outline, dtype=float)
    n = len(pts)
    if n < 4 or not np.all(np.isfinite(pts)):
        return []
    step = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    keep = np.nonzero(step > SAME_POINT_CM)[0]         # starts of segments with a direction
    m = len(keep)
    if m < 4:
        return []
    a = pts[keep]
    b = pts[(keep + 1) % n]
    pairs = _candidate_pairs(a, b)
    i, j = pairs[:, 0], pairs[:, 1]
    adjacent = (j == i + 1) | ((i == 0) & (j == m - 1))
    i, j = i[~adjacent], j[~adjacent]
    a1, b1, a2, b2 = a[i], b[i], a[j], b[j]
    d1, d2 = _orient(a1, b1, a2), _orient(a1, b1, b2)
    d3, d4 = _orient(a2, b2, a1), _orient(a2, b2, b1)
    hit = ((d1 * d2 < 0) & (d3 * d4 < 0)
           | (d1 == 0) & _on_segment(a1, b1, a2) | (d2 == 0) & _on_segment(a1, b1, b2)
           | (d3 == 0) & _on_segment(a2, b2, a1) | (d4 == 0) & _on_segment(a2, b2, b1))
    return sorted((int(keep[x]), int(keep[y])) for x, y in zip(i[hit], j[hit]))


def _seg(i: int, n: int) -> str:
    return f"{i}-{(i + 1) % n}"


def _listing(items: list, fmt) -> str:
    shown = ", ".join(fmt(x) for x in items[:_MAX_LISTED])
    return shown + (f" and {len(items) - _MAX_LISTED} more" if len(items) > _MAX_LISTED else "")


def _finite(*vals) -> bool:
    try:
        return bool(np.all(np.isfinite(np.asarray(vals, dtype=float))))
    except (TypeError, ValueError):
        return False


# ----------------------------------------------------------------------------- checks

def _check_outline(panel: Panel, where: str, rep: ValidationReport) -> bool:
    """Outline checks; False when the outline is too broken for the geometric checks."""
    o = np.asarray(panel.outline_cm, dtype=float)
    if o.ndim != 2 or o.shape[1] != 2:
        rep.errors.append(f"{where}: outline is not a list of [u, v] points (shape {o.shape})")
        return False
    n = len(o)
    if n < 3:
        rep.errors.append(f"{where}: open outline: {n} point(s), a closed outline needs at least 3")
        return False
    bad = np.nonzero(~np.all(np.isfinite(o), axis=1))[0].tolist()
    if bad:
        rep.errors.append(f"{where}: non-finite (NaN/inf) coordinates at outline vertex "
                          f"{_listing(bad, str)}")
        return False
    far = np.nonzero(np.abs(o).max(axis=1) > MAX_COORD_CM)[0].tolist()
    if far:
        one = len(far) == 1
        rep.errors.append(f"{where}: outline vert{'ex' if one else 'ices'} {_listing(far, str)} "
                          f"lie{'s' if one else ''} {np.abs(o[far[0]]).max():.3g} cm from the panel's origin, "
                          f"beyond {MAX_COORD_CM:.0f} cm (1 km): not a garment's coordinates")
        return False
    step = np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1)
    closing_dup = n >= 4 and step[-1] <= SAME_POINT_CM
    if closing_dup:
        msg = (f"{where}: outline vertex {n - 1} repeats vertex 0 (closed outlines list each "
               f"point once); fixable by dropping vertex {n - 1}")
        rep.warnings.append(msg)
        rep.fixable.append(msg)
    zero = [i for i in np.nonzero(step <= SAME_POINT_CM)[0].tolist() if not (closing_dup and i == n - 1)]
    if zero:
        rep.errors.append(f"{where}: zero-length outline segment(s) between vertices "
                          f"{_listing(zero, lambda i: _seg(i, n))} (duplicated points)")
    u, v = o[:, 0], o[:, 1]
    area = 0.5 * float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v))
    crossings = find_self_intersections(o)
    if crossings:
        rep.errors.append(f"{where}: self-intersecting outline: {len(crossings)} crossing(s), segments "
                          + _listing(crossings, lambda p: f"{_seg(p[0], n)} x {_seg(p[1], n)}"))
    elif abs(area) <= 1e-9:
        rep.errors.append(f"{where}: outline encloses no area")
    elif panel.orientation not in ("ccw", "cw"):
        rep.errors.append(f"{where}: orientation must be 'ccw' or 'cw', got {panel.orientation!r}")
    elif (area > 0) != (panel.orientation == "ccw"):
        rep.errors.append(f"{where}: declared orientation {panel.orientation!r} but the outline runs "
                          f"{'counter-clockwise' if area > 0 else 'clockwise'} (signed area {area:.1f} cm2)")
    return True


def _check_indices(panel: Panel, where: str, rep: ValidationReport) -> None:
    n = len(panel.outline_cm)
    for what, idx in (("node", panel.nodes), ("corner", panel.corners)):
        bad = [i for i in idx if not 0 <= i < n]
        if bad:
            rep.errors.append(f"{where}: {what} vertex index {_listing(bad, str)} outside the outline "
                              f"(0..{n - 1})")
    bad_lm = [f"{k!r}={i}" for k, i in panel.landmarks.items() if not 0 <= i < n]
    if bad_lm:
        rep.errors.append(f"{where}: landmark {_listing(bad_lm, str)} outside the outline (0..{n - 1})")


def _check_edges(panel: Panel, where: str, rep: ValidationReport, geometry_ok: bool) -> None:
    n = len(panel.outline_cm)
    spans = []
    for e in panel.edges:
        ew = f"{where} edge {e.id} ({e.kind})"
        if e.kind not in EDGE_KINDS:
            rep.errors.append(f"{ew}: unknown curve kind (expected one of {', '.join(EDGE_KINDS)})")
            continue
        if not (0 <= e.start < n and 0 <= e.end < n):
            rep.errors.append(f"{ew}: outline range {e.start}..{e.end} outside the outline (0..{n - 1})")
            continue
        if e.start == e.end:
            rep.errors.append(f"{ew}: degenerate edge: starts and ends at outline vertex {e.start}")
            continue
        spans.append((e.start, e.end, e.id))
        need = {"line": 0, "quadratic": 1, "cubic": 2}.get(e.kind)
        if need is not None and len(e.ctrl) != need:
            rep.errors.append(f"{ew}: needs {need} control point(s), has {len(e.ctrl)}")
            continue
        if not _finite(e.p0, e.p1) or (e.ctrl and not _finite(e.ctrl)):
            rep.errors.append(f"{ew}: non-finite (NaN/inf) curve point")
            continue
        if e.kind == "arc":
            a = e.arc if isinstance(e.arc, dict) else {}
            keys = ("center", "radius", "angle0_rad", "angle1_rad")
            if not all(k in a for k in keys):
                rep.errors.append(f"{ew}: 'arc' needs {', '.join(keys)}")
                continue
            if not (_finite(a["center"]) and _finite(a["radius"], a["angle0_rad"], a["angle1_rad"])):
                rep.errors.append(f"{ew}: non-finite (NaN/inf) arc parameter")
                continue
        if e.length_cm is not None and not _finite(e.length_cm):
            rep.errors.append(f"{ew}: non-finite length_cm")
        if not geometry_ok:
            continue
        o = np.asarray(panel.outline_cm, dtype=float)
        if e.kind == "line" and math.dist(e.p0, e.p1) <= SAME_POINT_CM:
            rep.errors.append(f"{ew}: degenerate edge: a line of zero length")
        off = max(math.dist(e.p0, o[e.start]), math.dist(e.p1, o[e.end]))
        if off > CURVE_OUTLINE_TOL_CM:
            rep.warnings.append(f"{ew}: curve end points are {off:.2f} cm from outline vertices "
                                f"{e.start} and {e.end}; the curve does not describe the outline")
    if spans and len(spans) == len(panel.edges):
        spans.sort()
        gaps = [(spans[k][2], spans[(k + 1) % len(spans)][2]) for k in range(len(spans))
                if spans[k][1] != spans[(k + 1) % len(spans)][0]]
        if gaps:
            rep.warnings.append(f"{where}: edges do not run end to start around the outline (after edge "
                                + _listing(gaps, lambda g: f"{g[0]} comes edge {g[1]}") + ")")


def _check_placement(panel: Panel, where: str, rep: ValidationReport) -> None:
    pl = panel.placement
    r = np.asarray(pl.rotation, dtype=float)
    t = np.asarray(pl.translation_m, dtype=float)
    if r.shape != (3, 3) or t.shape != (3,):
        rep.errors.append(f"{where}: placement needs a 3x3 rotation and a 3-vector translation")
        return
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
        rep.errors.append(f"{where}: non-finite (NaN/inf) placement "
                          f"{'rotation' if not np.all(np.isfinite(r)) else 'translation'}")
        return
    dev = float(np.abs(r.T @ r - np.eye(3)).max())
    det = float(np.linalg.det(r))
    if dev > ROTATION_TOL or det < 0:
        rep.errors.append(f"{where}: placement rotation is not a rotation (max |R^T R - I| = {dev:.2g}, "
                          f"det = {det:.3g})")


def _side_where(src: str, k: int, kind: str, tag: str, side: StitchSide) -> str:
    return f"{src}: stitch {k} ({kind}) side {tag} (panel {side.panel!r}, range {list(side.range)})"


def _check_stitches(pattern: Pattern, src: str, rep: ValidationReport, tol_cm: float,
                    tol_rel: float, good: dict[str, Panel]) -> None:
    names = {p.name: p for p in pattern.panels}
    for k, s in enumerate(pattern.stitches):
        sw = f"{src}: stitch {k} ({s.kind})"
        if s.orientation not in ("reversed", "same"):
            rep.errors.append(f"{sw}: orientation must be 'reversed' or 'same', got {s.orientation!r}")
        lengths, ranges = {}, {}
        for tag, side in (("a", s.a), ("b", s.b)):
            w = _side_where(src, k, s.kind, tag, side)
            if side.panel not in names:
                rep.errors.append(f"{w}: unknown panel {side.panel!r}")
                continue
            panel = names[side.panel]
            n = len(panel.outline_cm)
            bad = [i for i in side.range if not (isinstance(i, (int, np.integer)) and 0 <= i < n)]
            if bad:
                rep.errors.append(f"{w}: vertex {_listing(bad, str)} out of bounds (panel has "
                                  f"{n} vertices, 0..{n - 1})")
                continue
            if side.range[0] == side.range[1]:
                rep.errors.append(f"{w}: covers a single vertex; a stitch side needs at least one segment")
                continue
            if side.edge is not None and side.edge not in {e.id for e in panel.edges}:
                rep.errors.append(f"{w}: panel {side.panel!r} has no edge {side.edge!r}")
            if side.panel in good:
                idx = range_indices(side.range, n)
                ranges[tag] = set(idx.tolist())
                pts = np.asarray(panel.outline_cm, dtype=float)[idx]
                lengths[tag] = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        if len(ranges) == 2 and s.a.panel == s.b.panel and len(ranges["a"] & ranges["b"]) > 1:
            rep.errors.append(f"{sw}: sides a {list(s.a.range)} and b {list(s.b.range)} of panel "
                              f"{s.a.panel!r} overlap ({len(ranges['a'] & ranges['b'])} shared vertices)")
        if len(lengths) == 2 and not s.gathered:
            la, lb = lengths["a"], lengths["b"]
            tol = max(tol_cm, tol_rel * max(la, lb))
            if abs(la - lb) > tol:
                rep.errors.append(
                    f"{sw}: side lengths differ by {abs(la - lb):.2f} cm (a: panel {s.a.panel!r} "
                    f"{list(s.a.range)} {la:.2f} cm, b: panel {s.b.panel!r} {list(s.b.range)} {lb:.2f} cm), "
                    f"more than {tol:.2f} cm, and the stitch is not marked gathered")
        if len(ranges) == 2:
            for miss in notch_misses(names[s.a.panel], s.a.range, names[s.b.panel], s.b.range,
                                     orientation=s.orientation, gathered=bool(s.gathered)):
                rep.warnings.append(f"{sw}: notches out of step: {miss.describe()}")


def _check_units(pattern: Pattern, src: str, good: dict[str, Panel], rep: ValidationReport) -> None:
    if not good:
        return
    ext = {}
    for name, p in good.items():
        o = np.asarray(p.outline_cm, dtype=float)
        ext[name] = float((o.max(axis=0) - o.min(axis=0)).max())
    name = max(ext, key=ext.get)
    big = ext[name]
    if big > MM_EXTENT_CM:
        rep.errors.append(f"{src}: implausible units: the largest panel {name!r} is {big:.0f} cm across; "
                          f"the pattern looks like millimetres (sewpat-1 outlines are in cm)")
    elif big < M_EXTENT_CM:
        rep.errors.append(f"{src}: implausible units: the largest panel {name!r} is {big:.3g} cm across; "
                          f"the pattern looks like metres (sewpat-1 outlines are in cm)")


def validate_pattern(pattern: Pattern, *, seam_tolerance_cm: float = SEAM_TOLERANCE_CM,
                     seam_tolerance_rel: float = SEAM_TOLERANCE_REL) -> ValidationReport:
    """Check the pattern and list every problem found (nothing is raised)."""
    src = pattern.source_file or "<pattern>"
    rep = ValidationReport(source=src)
    if not pattern.panels:
        rep.errors.append(f"{src}: the pattern has no panels")
    seen: set[str] = set()
    good: dict[str, Panel] = {}
    for k, panel in enumerate(pattern.panels):
        where = f"{src}: panel {panel.name!r}"
        if not isinstance(panel.name, str) or not panel.name or not panel.name.isprintable():
            # control characters (a NUL, say) make drawings that are not valid XML
            rep.errors.append(f"{src}: panel {k} name {panel.name!r}: a name must be a non-empty string "
                              "of printable characters")
        if panel.name in seen:
            rep.errors.append(f"{where}: duplicate panel name (panel {k}); stitches could not tell them apart")
        seen.add(panel.name)
        geometry_ok = _check_outline(panel, where, rep)
        _check_indices(panel, where, rep)
        _check_edges(panel, where, rep, geometry_ok)
        _check_placement(panel, where, rep)
        if geometry_ok:
            good.setdefault(panel.name, panel)
    _check_units(pattern, src, good, rep)
    _check_stitches(pattern, src, rep, seam_tolerance_cm, seam_tolerance_rel, good)
    return rep


def check_pattern(pattern: Pattern, **tolerances) -> ValidationReport:
    """Validate and raise ValidationError (a PatternError) listing every error; returns the
    report (with any warnings) when there are none."""
    rep = validate_pattern(pattern, **tolerances)
    if rep.errors:
        raise ValidationError(f"{rep.source}: invalid pattern, {len(rep.errors)} error(s):\n"
                              + "\n".join(f"  - {m}" for m in rep.errors), rep.errors)
    return rep


# ----------------------------------------------------------------------------- fixes

def fix_pattern(pattern: Pattern) -> list[str]:
    """Repair, in place, what :func:`validate_pattern` reports as fixable: an outline whose
    last vertex repeats the first. Indices of nodes, corners, landmarks, edges and stitch
    ranges that pointed at the dropped vertex move to vertex 0. Returns what was done."""
    done = []
    src = pattern.source_file or "<pattern>"
    for panel in pattern.panels:
        o = np.asarray(panel.outline_cm, dtype=float)
        n = len(o)
        if n < 4 or not np.all(np.isfinite(o[[0, -1]])) or np.linalg.norm(o[-1] - o[0]) > SAME_POINT_CM:
            continue
        last = n - 1

        def m(i: int) -> int:
            return 0 if i == last else i

        panel.outline_cm = o[:-1].copy()
        panel.nodes = list(dict.fromkeys(m(i) for i in panel.nodes))
        panel.corners = list(dict.fromkeys(m(i) for i in panel.corners))
        panel.landmarks = {k: m(i) for k, i in panel.landmarks.items()}
        kept = []
        for e in panel.edges:
            if e.start == last and e.end == 0:
                continue                                 # the zero-length closing piece
            e.start, e.end = m(e.start), m(e.end)
            kept.append(e)
        panel.edges = kept
        for s in pattern.stitches:
            for side in (s.a, s.b):
                if side.panel == panel.name:
                    side.range = (m(side.range[0]), m(side.range[1]))
        done.append(f"{src}: panel {panel.name!r}: dropped outline vertex {last} (a repeat of vertex 0)")
    return done
