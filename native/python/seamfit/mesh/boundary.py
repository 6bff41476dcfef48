"""Boundary sampling: place the boundary vertices of every panel so that sewing pairs them one to one.

Positions on a panel outline are arc lengths ``s`` (cm) along the closed ``outline_cm`` polyline,
measured from outline point 0 in index order. Every panel is cut at *breakpoints*: its nodes,
corners and landmarks and the two ends of every stitch range on it. Breakpoints always become
vertices, at the exact outline point.

A stitch joins side ``a`` and side ``b``. Both sides get the same vertex count:

* The interior breakpoints of each side, as arc-length fractions of that side (fractions of ``b``
  read in ``a``'s direction when the stitch is ``reversed``), are put on *both* sides.
* A breakpoint of ``a`` and one of ``b`` that fall within ``merge_tolerance`` (default half the
  edge length) of each other are one feature drafted slightly differently on the two sides (a
  knee or hip node on an outseam); they are matched to each other instead of each being copied to
  the other side, which would leave a sliver of outline much shorter than the edge length. Other
  breakpoints are copied through the piecewise-linear map between matched ones (with no matches
  that is the identity: both sides at identical fractions).
* Each piece between consecutive breakpoints gets ``max(1, round(L / h))`` segments, ``L`` being
  the longer of its two sides, and both sides are cut at the same fractions of the piece, so a
  gathered side (longer than its partner) spreads its vertices in proportion.

Stretches of outline in no stitch are cut between breakpoints into ``max(1, round(L / h))``
equal arcs. Stitch ranges on one panel may share end points (consecutive seams, dart tips) but no
outline segment may be sewn twice.

Near a gap between breakpoints much shorter than h the spacing is graded (``_SizeField``): it
shrinks to the gap and grows back to h at SIZE_GRADIENT, and pieces are cut by equidistributing
length / spacing, so no short segment sits next to a long one. Without short gaps this is the
uniform cutting above. See docs/meshing.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PatternError
from ..pattern.model import Panel, Pattern, Stitch

# The default mesh for draping and grading: on all 57 shared cases the landmark error of a
# grading does not fall with a finer mesh, and 3 cm reaches it in half the time or less
# (docs/accuracy_time.md); a finer mesh holds the ease 0.1-0.2 cm closer.
DEFAULT_EDGE_LENGTH_CM = 3.0
# Two arc positions closer than this (cm) are one vertex: zero-length outline segments and
# float noise on positions computed along different stitches.
SAME_POINT_CM = 1e-7
# Gaps between breakpoints shorter than SHORT_GAP * h grade the spacing around them; the spacing
# grows by SIZE_GRADIENT cm per cm of arc away from such a gap (about 20 % per segment).
SHORT_GAP = 0.8
SIZE_GRADIENT = 0.2
MAX_GRADING_PASSES = 10


@dataclass
class PanelBoundary:
    """The boundary vertices of one panel, in outline order (increasing arc position)."""
    name: str
    index: int                      # panel index in the pattern
    outline_cm: np.ndarray          # (n, 2) the panel outline
    arc: np.ndarray                 # (n + 1,) arc position of every outline point, arc[n] = perimeter
    s: np.ndarray                   # (m,) arc position of every boundary vertex, 0 <= s < perimeter
    uv: np.ndarray                  # (m, 2) cm, on the outline polyline
    outline_index: np.ndarray       # (m,) the outline point a vertex sits on, -1 if between points
    corner: np.ndarray              # (m,) bool, the vertex is one of the panel's corners
    landmarks: dict[str, int]       # landmark name -> local vertex

    @property
    def perimeter(self) -> float:
        return float(self.arc[-1])


@dataclass
class StitchSamples:
    """The vertex pairs of one stitch, in the direction of side a."""
    index: int                      # stitch index in the pattern
    panel_a: int
    panel_b: int
    a: np.ndarray                   # (k,) local boundary vertices on panel a, a-forward order
    b: np.ndarray                   # (k,) the vertices of panel b sewn to them
    frac_a: np.ndarray              # (k,) arc fraction along side a (0 at its range start)
    frac_b: np.ndarray              # (k,) arc fraction along side b, in b's own forward direction
    # (j, 2) breakpoints, matched or copied: fraction along a, fraction along b in a's direction
    knots: np.ndarray


@dataclass
class PatternBoundary:
    panels: list[PanelBoundary]
    stitches: list[StitchSamples]
    edge_length_cm: float
    merge_tolerance_cm: float


def _src(pattern: Pattern) -> str:
    return pattern.source_file or "<pattern>"


def arc_positions(outline: np.ndarray) -> np.ndarray:
    closed = np.vstack([outline, outline[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(seg)])


def point_at(outline: np.ndarray, arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Points on the closed polyline at arc positions s (taken modulo the perimeter)."""
    closed = np.vstack([outline, outline[:1]])
    s = np.mod(np.asarray(s, dtype=float), arc[-1])
    return np.column_stack([np.interp(s, arc, closed[:, 0]), np.interp(s, arc, closed[:, 1])])


# ----------------------------------------------------------------------------- validation

def validate_for_meshing(pattern: Pattern) -> None:
    """Raise PatternError (naming file, panel, stitch, vertex) for anything meshing cannot use."""
    src = _src(pattern)
    names = [p.name for p in pattern.panels]
    if not pattern.panels:
        raise PatternError(f"{src}: the pattern has no panels")
    for name in names:
        if names.count(name) > 1:
            raise PatternError(f"{src}: panel name {name!r} is used by {names.count(name)} panels")
    for p in pattern.panels:
        _validate_panel(src, p)
    covered = {p.name: {} for p in pattern.panels}     # panel -> {segment: (stitch, side)}
    for k, st in enumerate(pattern.stitches):
        if st.orientation not in ("reversed", "same"):
            raise PatternError(f"{src}: stitch {k}: orientation must be 'reversed' or 'same', "
                               f"got {st.orientation!r}")
        for side_name, side in (("a", st.a), ("b", st.b)):
            where = f"{src}: stitch {k} side {side_name}"
            if side.panel not in covered:
                raise PatternError(f"{where}: unknown panel {side.panel!r} "
                                   f"(the pattern has {', '.join(map(repr, names))})")
            panel = pattern.panel(side.panel)
            n = panel.n_vertices
            i0, i1 = side.range
            for i in (i0, i1):
                if not 0 <= i < n:
                    raise PatternError(f"{where}: range [{i0}, {i1}] on panel {side.panel!r} names vertex "
                                       f"{i}, outside the outline (0..{n - 1})")
            if i0 == i1:
                raise PatternError(f"{where}: range [{i0}, {i1}] on panel {side.panel!r} is a single point")
            arc = arc_positions(panel.outline_cm)
            if (arc[i1] - arc[i0]) % arc[-1] <= SAME_POINT_CM:
                raise PatternError(f"{where}: range [{i0}, {i1}] on panel {side.panel!r} has zero length")
            seen = covered[side.panel]
            for j in range(i0, i0 + (i1 - i0) % n):
                seg = j % n
                if seg in seen and not _zero_segment(arc, seg):
                    other_k, other_side = seen[seg]
                    raise PatternError(
                        f"{where}: outline segment {seg}..{(seg + 1) % n} of panel {side.panel!r} is "
                        f"already sewn by stitch {other_k} side {other_side}; a segment can be sewn once")
                seen[seg] = (k, side_name)


def _zero_segment(arc: np.ndarray, seg: int) -> bool:
    return arc[seg + 1] - arc[seg] <= SAME_POINT_CM


def _validate_panel(src: str, p: Panel) -> None:
    where = f"{src}: panel {p.name!r}"
    o = np.asarray(p.outline_cm, dtype=float)
    if o.ndim != 2 or o.shape[1] != 2 or len(o) < 3:
        raise PatternError(f"{where}: outline_cm must hold at least 3 [u, v] points")
    bad = np.nonzero(~np.isfinite(o).all(axis=1))[0]
    if len(bad):
        raise PatternError(f"{where}: outline vertex {int(bad[0])} is not finite")
    n = len(o)
    for kind, idx in (("node", p.nodes), ("corner", p.corners)):
        for i in idx:
            if not 0 <= i < n:
                raise PatternError(f"{where}: {kind} index {i} is outside the outline (0..{n - 1})")
    for name, i in p.landmarks.items():
        if not 0 <= i < n:
            raise PatternError(f"{where}: landmark {name!r} names vertex {i}, outside the outline (0..{n - 1})")
    area = p.signed_area_cm2()
    if abs(area) <= 1e-9:
        raise PatternError(f"{where}: the outline encloses no area")
    if p.orientation not in ("ccw", "cw"):
        raise PatternError(f"{where}: orientation must be 'ccw' or 'cw', got {p.orientation!r}")
    if (area > 0) != (p.orientation == "ccw"):
        raise PatternError(f"{where}: orientation says {p.orientation!r} but the outline runs "
                           f"{'ccw' if area > 0 else 'cw'} (signed area {area:.3f} cm^2); the outward "
                           "normal would be ambiguous")


# ----------------------------------------------------------------------------- sampling

class _Candidates:
    """Arc positions proposed as vertices of one panel, with what they carry."""

    def __init__(self, perimeter: float):
        self.perimeter = perimeter
        self.s: list[float] = []
        self.outline_index: list[int] = []

    def add(self, s: float, outline_index: int = -1) -> None:
        self.s.append(float(s) % self.perimeter)
        self.outline_index.append(int(outline_index))


def _side_info(panel: Panel, arc: np.ndarray, rng: tuple[int, int], breaks: set[int]):
    """Start position, length, and the interior breakpoints (fraction, outline index) of a range."""
    n = panel.n_vertices
    i0, i1 = rng
    per = arc[-1]
    start = arc[i0]
    length = (arc[i1] - arc[i0]) % per
    inner = []
    for step in range(1, (i1 - i0) % n):
        i = (i0 + step) % n
        if i in breaks:
            f = ((arc[i] - start) % per) / length
            if SAME_POINT_CM / length < f < 1.0 - SAME_POINT_CM / length:
                inner.append((f, i))
    return start, length, inner


def _match_knots(fa: list[tuple[float, int]], fb: list[tuple[float, int]], scale: float, tol: float):
    """Match breakpoints of side a and side b (both as fractions in a's direction) that lie within tol.

    Returns knots [(fa, fb, ia, ib)] sorted, including the ends; ia / ib = outline index on that
    side when the knot is one of its own breakpoints, else -1.
    """
    events = sorted([(f, 0, i) for f, i in fa] + [(f, 1, i) for f, i in fb])
    # Candidate matches: neighbours in sorted order from different sides, closest first. Taking
    # disjoint neighbouring pairs keeps the matched knots increasing on both sides.
    cands = sorted((events[j + 1][0] - events[j][0], j) for j in range(len(events) - 1)
                   if events[j][1] != events[j + 1][1])
    used = [False] * len(events)
    pairs = []
    for d, j in cands:
        if d * scale < tol and not used[j] and not used[j + 1]:
            used[j] = used[j + 1] = True
            pairs.append(j)
    knots = [(0.0, 0.0, -1, -1), (1.0, 1.0, -1, -1)]
    for j in pairs:
        ea, eb = (events[j], events[j + 1]) if events[j][1] == 0 else (events[j + 1], events[j])
        knots.append((ea[0], eb[0], ea[2], eb[2]))
    knots.sort()
    ka = np.array([k[0] for k in knots])
    kb = np.array([k[1] for k in knots])
    for j, (f, side, i) in enumerate(events):
        if used[j]:
            continue
        if side == 0:
            knots.append((f, float(np.interp(f, ka, kb)), i, -1))
        else:
            knots.append((float(np.interp(f, kb, ka)), f, -1, i))
    knots.sort()
    out = [knots[0]]
    for k in knots[1:]:
        if k[0] - out[-1][0] > 1e-12 and k[1] - out[-1][1] > 1e-12:
            out.append(k)
        elif k[0] >= 1.0 or k[1] >= 1.0:       # keep the exact end knot
            out[-1] = k
        else:                                  # the same point twice: keep what is exact
            prev = out[-1]
            out[-1] = (prev[0], prev[1], max(prev[2], k[2]), max(prev[3], k[3]))
    return out


def sample_boundary(pattern: Pattern, edge_length_cm: float = DEFAULT_EDGE_LENGTH_CM,
                    merge_tolerance_cm: float | None = None) -> PatternBoundary:
    """Place the boundary vertices of every panel (see the module docstring)."""
    h = float(edge_length_cm)
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"edge length must be a positive number of cm, got {edge_length_cm!r}")
    tol = 0.5 * h if merge_tolerance_cm is None else float(merge_tolerance_cm)
    validate_for_meshing(pattern)

    panels = pattern.panels
    arcs = [arc_positions(p.outline_cm) for p in panels]
    breaks: list[set[int]] = []
    for p in panels:
        breaks.append(set(p.nodes) | set(p.corners) | set(p.landmarks.values()))
    for st in pattern.stitches:
        for side in (st.a, st.b):
            breaks[pattern.panel_index(side.panel)].update(side.range)

    # 1. Breakpoints: every panel's own, plus those copied across stitches.
    fixed = [_Candidates(float(a[-1])) for a in arcs]
    for k in range(len(panels)):
        for i in sorted(breaks[k]):
            fixed[k].add(arcs[k][i], i)
    knots = []
    for k, st in enumerate(pattern.stitches):
        kn = _stitch_knots(pattern, st, arcs, breaks, tol)
        knots.append(kn)
        for side, pos in (("a", kn.pos_a), ("b", kn.pos_b)):
            kp = kn.panel_a if side == "a" else kn.panel_b
            for s in pos:
                fixed[kp].add(s)
    merged = [_merge_positions(c, arcs[k]) for k, c in enumerate(fixed)]

    # 2. Target spacing along each outline: h, graded down towards gaps shorter than h. A stitch
    # cuts both sides as densely as the denser one needs, which can bring a short segment to the
    # partner panel; the spacing is then graded around that too, until nothing changes.
    sewn = [_sewn_segments(pattern, k, arcs[k]) for k in range(len(panels))]
    sizes = [_SizeField(s, arcs[k][-1], h) for k, (s, _) in enumerate(merged)]
    for _ in range(MAX_GRADING_PASSES):
        samples, raw_pairs = _sample_all(merged, knots, arcs, sizes, sewn)
        imported = [sizes[k].import_short(s) for k, (s, _) in enumerate(samples)]
        if not any(imported):
            break

    # 3. The boundary vertices.
    bounds = []
    for k, p in enumerate(panels):
        s, oi = samples[k]
        if len(s) < 3:
            raise PatternError(f"{_src(pattern)}: panel {p.name!r}: only {len(s)} boundary vertices at edge "
                               f"length {h:g} cm; use a shorter edge length")
        uv = point_at(p.outline_cm, arcs[k], s)
        exact = oi >= 0
        uv[exact] = p.outline_cm[oi[exact]]
        where = {int(i): v for v, i in enumerate(oi) if i >= 0}
        corner = np.zeros(len(s), dtype=bool)
        for i in p.corners:
            corner[where[_first_same(arcs[k], i, where)]] = True
        landmarks = {name: where[_first_same(arcs[k], i, where)] for name, i in p.landmarks.items()}
        bounds.append(PanelBoundary(name=p.name, index=k, outline_cm=p.outline_cm, arc=arcs[k], s=s,
                                    uv=uv, outline_index=oi, corner=corner, landmarks=landmarks))

    stitches = []
    for k, (st, (sa, sb, fa, fb, kn)) in enumerate(zip(pattern.stitches, raw_pairs)):
        ka, kb = pattern.panel_index(st.a.panel), pattern.panel_index(st.b.panel)
        va = _lookup(bounds[ka], sa, pattern, k, "a")
        vb = _lookup(bounds[kb], sb, pattern, k, "b")
        # Every vertex inside a stitch range must be sewn, or the two sides would not match.
        for side, kp, v in ((st.a, ka, va), (st.b, kb, vb)):
            inside = vertices_in_range(bounds[kp], side.range)
            expect = v if side is st.a or st.orientation == "same" else v[::-1]
            if not np.array_equal(inside, expect):
                raise AssertionError(f"{_src(pattern)}: stitch {k}: panel {side.panel!r} has {len(inside)} "
                                     f"vertices in range {list(side.range)} but {len(v)} are sewn")
        stitches.append(StitchSamples(index=k, panel_a=ka, panel_b=kb, a=va, b=vb, frac_a=fa, frac_b=fb,
                                      knots=kn))
    return PatternBoundary(panels=bounds, stitches=stitches, edge_length_cm=h, merge_tolerance_cm=tol)


def vertices_in_range(b: PanelBoundary, rng: tuple[int, int]) -> np.ndarray:
    """Local boundary vertices on the outline range i0..i1 (forward, wrapping, ends included), in order."""
    per = b.perimeter
    i0, i1 = rng
    start = b.arc[i0]
    length = (b.arc[i1] - start) % per
    off = np.mod(b.s - start, per)
    off[per - off <= SAME_POINT_CM] = 0.0
    sel = np.nonzero(off <= length + SAME_POINT_CM)[0]
    return sel[np.argsort(off[sel], kind="stable")]


def _first_same(arc: np.ndarray, i: int, where: dict[int, int]) -> int:
    """The outline index that stands for point i (points on zero-length segments share one vertex)."""
    if i in where:
        return i
    for j in where:
        if abs(arc[j] - arc[i]) <= SAME_POINT_CM or abs(abs(arc[j] - arc[i]) - arc[-1]) <= SAME_POINT_CM:
            return j
    raise AssertionError(f"outline point {i} has no vertex")


@dataclass
class _Knots:
    """Matched breakpoints of one stitch: fractions (f along a, g along b read in a's direction)
    and arc positions on both panels (exact outline points where the knot is one)."""
    panel_a: int
    panel_b: int
    reversed: bool
    a0: float
    la: float
    b0: float
    lb: float
    f: np.ndarray
    g: np.ndarray
    pos_a: np.ndarray
    pos_b: np.ndarray


def _stitch_knots(pattern: Pattern, st: Stitch, arcs, breaks, tol: float) -> _Knots:
    ka, kb = pattern.panel_index(st.a.panel), pattern.panel_index(st.b.panel)
    a0, la, inner_a = _side_info(pattern.panels[ka], arcs[ka], st.a.range, breaks[ka])
    b0, lb, inner_b = _side_info(pattern.panels[kb], arcs[kb], st.b.range, breaks[kb])
    rev = st.orientation == "reversed"
    inner_b_in_a = [((1.0 - f) if rev else f, i) for f, i in inner_b]
    kn = _match_knots(inner_a, inner_b_in_a, max(la, lb), tol)
    (ia0, ia1), (ib0, ib1) = st.a.range, st.b.range
    kn[0] = (0.0, 0.0, ia0, ib1 if rev else ib0)
    kn[-1] = (1.0, 1.0, ia1, ib0 if rev else ib1)
    f = np.array([x[0] for x in kn])
    g = np.array([x[1] for x in kn])
    pos_a = np.array([arcs[ka][i] if i >= 0 else a0 + fx * la for fx, _, i, _ in kn])
    gb = 1.0 - g if rev else g
    pos_b = np.array([arcs[kb][i] if i >= 0 else b0 + gx * lb for gx, (_, _, _, i) in zip(gb, kn)])
    return _Knots(ka, kb, rev, a0, la, b0, lb, f, g, np.mod(pos_a, arcs[ka][-1]), np.mod(pos_b, arcs[kb][-1]))


def _sample_stitch(kn: _Knots, arcs, sizes, cands):
    """Cut every piece between knots into the same number of segments on both sides."""
    fa_all, ga_all = [], []
    for j in range(len(kn.f) - 1):
        f0, f1, g0, g1 = kn.f[j], kn.f[j + 1], kn.g[j], kn.g[j + 1]
        grid = _piece_grid(max(kn.la * (f1 - f0), kn.lb * (g1 - g0)), sizes[kn.panel_a].h)
        pa = kn.a0 + (f0 + grid * (f1 - f0)) * kn.la
        gb = g0 + grid * (g1 - g0)
        pb = kn.b0 + ((1.0 - gb) if kn.reversed else gb) * kn.lb
        # segments per unit of piece parameter: the denser of the two sides
        density = np.maximum(kn.la * (f1 - f0) / sizes[kn.panel_a](pa),
                             kn.lb * (g1 - g0) / sizes[kn.panel_b](pb))
        t = _equidistribute(grid, density)
        fa_all.append(f0 + t[:-1] * (f1 - f0))
        ga_all.append(g0 + t[:-1] * (g1 - g0))
    fa = np.concatenate(fa_all + [[1.0]])
    ga = np.concatenate(ga_all + [[1.0]])
    fb = 1.0 - ga if kn.reversed else ga        # b's own direction
    sa = kn.a0 + fa * kn.la
    sb = kn.b0 + fb * kn.lb
    at = np.cumsum([0] + [len(x) for x in fa_all])   # where each knot sits in the samples
    sa[at] = kn.pos_a
    sb[at] = kn.pos_b
    sa, sb = np.mod(sa, arcs[kn.panel_a][-1]), np.mod(sb, arcs[kn.panel_b][-1])
    for s in sa:
        cands[kn.panel_a].add(s)
    for s in sb:
        cands[kn.panel_b].add(s)
    return sa, sb, fa, fb, np.column_stack([kn.f, kn.g])


def _sample_all(merged, knots, arcs, sizes, sewn):
    """Sample all stitches, then the free stretches: per panel (arc positions, outline indices)."""
    cands = [_Candidates(float(a[-1])) for a in arcs]
    for k, (s, oi) in enumerate(merged):
        for x, i in zip(s, oi):
            cands[k].add(x, i)
    raw_pairs = [_sample_stitch(kn, arcs, sizes, cands) for kn in knots]
    samples = []
    for k, c in enumerate(cands):
        s, oi = _merge_positions(c, arcs[k])
        samples.append(_fill_free(s, oi, arcs[k], sewn[k], sizes[k]))
    return samples, raw_pairs


def _piece_grid(length: float, h: float) -> np.ndarray:
    """Parameter grid on [0, 1] fine enough to integrate the segment density of a piece."""
    return np.linspace(0.0, 1.0, 2 + int(np.ceil(length / (0.05 * h))))


def _equidistribute(grid: np.ndarray, density: np.ndarray) -> np.ndarray:
    """Cut [0, 1] into round(integral of density) parts holding equal amounts of density."""
    if np.ptp(density) <= 1e-12 * density.max():
        n = max(1, int(round(density[0])))
        return np.arange(n + 1) / n
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(grid))])
    n = max(1, int(round(cum[-1])))
    t = np.interp(np.arange(n + 1) * cum[-1] / n, cum, grid)
    t[0], t[-1] = 0.0, 1.0
    return t


class _SizeField:
    """Target boundary spacing along one outline: h, shrinking to the length of any gap between
    consecutive breakpoints shorter than SHORT_GAP * h, growing away from it at SIZE_GRADIENT
    (cm per cm of arc), so neighbouring segments differ by about that ratio and no thin triangle
    has to close a short segment next to a long one."""

    def __init__(self, fixed_s: np.ndarray, perimeter: float, h: float):
        self.h = h
        self.per = perimeter
        s = np.sort(np.asarray(fixed_s, dtype=float))
        gaps = np.diff(np.concatenate([s, [s[0] + perimeter]])) if len(s) else np.zeros(0)
        short = gaps < SHORT_GAP * h
        self.start = list(s[short])
        self.length = list(gaps[short])

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.atleast_1d(np.asarray(s, dtype=float))
        out = np.full(s.shape, self.h)
        for st, ln in zip(self.start, self.length):
            off = np.mod(s - st, self.per)
            dist = np.where(off <= ln, 0.0, np.minimum(off - ln, self.per - off))
            out = np.minimum(out, ln + SIZE_GRADIENT * dist)
        return out

    def import_short(self, s: np.ndarray) -> bool:
        """Take in segments of a sampling clearly shorter than this field asks for (they come from
        the partner side of a stitch). Returns whether any was new."""
        if len(s) < 2:
            return False
        seg = np.diff(np.concatenate([s, [s[0] + self.per]]))
        want = self(s + 0.5 * seg)
        new = np.nonzero(seg < 0.9 * want)[0]
        self.start.extend(s[new])
        self.length.extend(seg[new])
        return bool(len(new))


def _merge_positions(c: _Candidates, arc: np.ndarray):
    """Sorted unique arc positions; an outline point wins over a computed position at the same place."""
    per = c.perimeter
    s = np.array(c.s)
    oi = np.array(c.outline_index, dtype=np.int64)
    s[per - s <= SAME_POINT_CM] = 0.0          # the end of the loop is its start
    order = np.lexsort((oi < 0, s))            # by position, outline points first
    s, oi = s[order], oi[order]
    keep_s, keep_i = [], []
    for x, i in zip(s, oi):
        if keep_s and x - keep_s[-1] <= SAME_POINT_CM:
            if keep_i[-1] < 0 and i >= 0:
                keep_s[-1], keep_i[-1] = arc[i], i
            continue
        keep_s.append(x)
        keep_i.append(i)
    return np.array(keep_s), np.array(keep_i, dtype=np.int64)


def _sewn_segments(pattern: Pattern, k: int, arc: np.ndarray) -> list[tuple[float, float]]:
    """Arc intervals (start, length) of panel k covered by stitch ranges."""
    name = pattern.panels[k].name
    out = []
    for st in pattern.stitches:
        for side in (st.a, st.b):
            if side.panel == name:
                i0, i1 = side.range
                out.append((arc[i0], (arc[i1] - arc[i0]) % arc[-1]))
    return out


def _fill_free(s: np.ndarray, oi: np.ndarray, arc: np.ndarray, sewn, size: _SizeField):
    """Add vertices along gaps between consecutive positions that no stitch covers."""
    per = arc[-1]
    if len(s) == 0:
        s, oi = np.array([0.0]), np.array([0], dtype=np.int64)
    new_s = []
    for j in range(len(s)):
        x0 = s[j]
        x1 = s[j + 1] if j + 1 < len(s) else s[0] + per
        gap = x1 - x0
        mid = x0 + 0.5 * gap
        if any(((mid - st) % per) < ln for st, ln in sewn):
            continue
        grid = _piece_grid(gap, size.h)
        t = _equidistribute(grid, gap / size(x0 + grid * gap))
        if len(s) == 1 and len(t) < 4:         # a lone breakpoint: at least a triangle
            t = np.linspace(0.0, 1.0, 4)
        new_s.extend(np.mod(x0 + t[1:-1] * gap, per))
    if new_s:
        s = np.concatenate([s, new_s])
        oi = np.concatenate([oi, -np.ones(len(new_s), dtype=np.int64)]).astype(np.int64)
        order = np.argsort(s, kind="stable")
        s, oi = s[order], oi[order]
    return s, oi


def _lookup(b: PanelBoundary, s: np.ndarray, pattern: Pattern, k: int, side: str) -> np.ndarray:
    """The boundary vertex at each arc position s (which must be one)."""
    per, m = b.perimeter, len(b.s)
    j = np.searchsorted(b.s, s)
    cand = np.stack([np.mod(j - 1, m), np.mod(j, m)])
    d = np.abs(s[None, :] - b.s[cand])
    d = np.minimum(d, per - d)
    pick = np.argmin(d, axis=0)
    v = cand[pick, np.arange(len(s))]
    dist = d[pick, np.arange(len(s))]
    if np.any(dist > 1e-6):
        bad = int(np.argmax(dist))
        raise AssertionError(f"{_src(pattern)}: stitch {k} side {side} on panel {b.name!r}: sample {bad} "
                             f"at arc {s[bad]:.6f} cm has no boundary vertex")
    return v.astype(np.int64)
