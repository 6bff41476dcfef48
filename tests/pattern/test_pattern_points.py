"""seamfit.pattern.points: an edge split at a new point, two edges joined where a point is deleted."""
import copy

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import curves, load_pattern, range_indices, validate_pattern
from seamfit.pattern.points import join_edges, point_roles, split_edge
from seamfit.pattern.sewpat import pattern_to_dict
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
PENCIL = PATTERNS / "gc_pencil_skirt" / "size06" / "pattern.json"
CIRCLE = PATTERNS / "gc_circle_skirt" / "size06" / "pattern.json"


def _sides(pattern, panel_name):
    return [(k, tag, side) for k, s in enumerate(pattern.stitches)
            for tag, side in (("a", s.a), ("b", s.b)) if side.panel == panel_name]


def _arc_length(panel, side):
    pts = panel.outline_cm[range_indices(side.range, panel.n_vertices)]
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def _stitched_edge(pattern, kind):
    """A panel and an edge of that kind which some stitch side covers whole."""
    for pn in pattern.panels:
        for e in pn.edges:
            if e.kind == kind and any(side.range == (e.start, e.end) for _, _, side in _sides(pattern, pn.name)):
                return pn, e
    raise AssertionError(f"no stitched {kind} edge")


@pytest.mark.parametrize("path,kind", [(PENCIL, "quadratic"), (PENCIL, "line"), (CIRCLE, "arc")])
def test_a_split_edge_keeps_its_curve_and_its_stitches(path, kind):
    base = load_pattern(path)
    keep = copy.deepcopy(base)
    pn, e = _stitched_edge(base, kind)
    at = curves.evaluate(e, [0.4])[0] + [0.3, -0.2]          # off the curve: split at its nearest point
    out, new_id = split_edge(base, pn.name, e.id, at)
    assert validate_pattern(out).ok
    assert pattern_to_dict(base) == pattern_to_dict(keep)     # the input is not modified
    op = out.panel(pn.name)
    assert new_id == max(x.id for x in pn.edges) + 1 and len({x.id for x in op.edges}) == len(op.edges)
    first, second = (next(x for x in op.edges if x.id == i) for i in (e.id, new_id))
    assert first.end == second.start and second.start in op.nodes
    assert (first.kind, second.kind) == (e.kind, e.kind)
    assert np.allclose(first.p1, second.p0) and first.p0 == e.p0 and second.p1 == e.p1
    # Both halves lie on the old curve, and so does the outline between them.
    for half in (first, second):
        idx = (half.start + np.arange((half.end - half.start) % op.n_vertices + 1)) % op.n_vertices
        assert curves.distance_to_curve(e, op.outline_cm[idx]).max() < 1e-4
        assert curves.distance_to_curve(e, curves.sample_by_length(half, 0.5)).max() < 1e-4
    assert curves.length(first) + curves.length(second) == pytest.approx(curves.length(e), abs=1e-6)
    # Every stitch sews the same stretch of boundary: its ends at the same points, its
    # length the same within 1 mm; the side over the whole edge now spans both halves.
    for (k, tag, old), (_, _, new) in zip(_sides(base, pn.name), _sides(out, pn.name)):
        assert np.allclose(op.outline_cm[list(new.range)], pn.outline_cm[list(old.range)])
        assert _arc_length(op, new) == pytest.approx(_arc_length(pn, old), abs=0.1)
        if old.range == (e.start, e.end):
            assert new.range == (first.start, second.end)
    # Corners and landmarks stay on their points.
    assert np.array_equal(op.outline_cm[op.corners], pn.outline_cm[pn.corners])
    assert all(np.array_equal(op.outline_cm[op.landmarks[k]], pn.outline_cm[i]) for k, i in pn.landmarks.items())


@pytest.mark.parametrize("path,kind", [(PENCIL, "quadratic"), (PENCIL, "line"), (CIRCLE, "arc")])
def test_split_then_join_gives_the_edge_back(path, kind):
    base = load_pattern(path)
    pn, e = _stitched_edge(base, kind)
    out, new_id = split_edge(base, pn.name, e.id, curves.evaluate(e, [0.63])[0])
    keep = copy.deepcopy(out)
    back = join_edges(out, pn.name, e.id, new_id)
    assert pattern_to_dict(out) == pattern_to_dict(keep)
    assert validate_pattern(back).ok
    bp = back.panel(pn.name)
    assert sorted(x.id for x in bp.edges) == sorted(x.id for x in pn.edges)
    ne = next(x for x in bp.edges if x.id == e.id)
    assert ne.kind == ("cubic" if kind == "quadratic" else kind)      # a quadratic comes back as its cubic
    # The boundary within sampling tolerance: the new curve and its outline on the old curve,
    # at most 1 cm apart; nodes, corners and stitch ends at the same points.
    idx = (ne.start + np.arange((ne.end - ne.start) % bp.n_vertices + 1)) % bp.n_vertices
    assert curves.distance_to_curve(e, bp.outline_cm[idx]).max() < 1e-3
    assert curves.distance_to_curve(e, curves.sample_by_length(ne, 0.5)).max() < 1e-3
    assert np.linalg.norm(np.diff(bp.outline_cm[idx], axis=0), axis=1).max() <= 1.0 + 1e-9
    assert curves.length(ne) == pytest.approx(curves.length(e), abs=1e-3)
    for field in ("nodes", "corners"):
        assert np.allclose(sorted(map(tuple, bp.outline_cm[getattr(bp, field)])),
                           sorted(map(tuple, pn.outline_cm[getattr(pn, field)])), atol=1e-3)
    for (_, _, old), (_, _, new) in zip(_sides(base, pn.name), _sides(back, pn.name)):
        assert np.allclose(bp.outline_cm[list(new.range)], pn.outline_cm[list(old.range)], atol=1e-3)
        assert _arc_length(bp, new) == pytest.approx(_arc_length(pn, old), abs=0.1)


def test_a_point_that_the_pattern_uses_is_not_deleted():
    base = load_pattern(PENCIL)
    pn, e = _stitched_edge(base, "line")
    out, new_id = split_edge(base, pn.name, e.id, curves.evaluate(e, [0.5])[0])
    v = next(x for x in out.panel(pn.name).edges if x.id == new_id).start
    assert point_roles(out, pn.name, v) == []                 # a point of its own: it joins back
    # The same point as a stitch end, a corner and a landmark, each refused in one line.
    as_stitch_end = copy.deepcopy(out)
    side = next(side for _, _, side in _sides(as_stitch_end, pn.name) if side.range[0] == e.start)
    side.range = (v, side.range[1])
    as_corner = copy.deepcopy(out)
    as_corner.panel(pn.name).corners.append(v)
    as_landmark = copy.deepcopy(out)
    as_landmark.panel(pn.name).landmarks["pocket"] = v
    for pattern, says in ((as_stitch_end, r"an end of stitch \d+ \(\w+\) side [ab]"), (as_corner, "a corner"),
                          (as_landmark, "landmark 'pocket'")):
        with pytest.raises(PatternError, match=f"panel '{pn.name}': point 7 cannot be deleted: it is {says}") as info:
            join_edges(pattern, pn.name, e.id, new_id, point="point 7")
        assert "\n" not in str(info.value)
    # Points of the sample pattern: every node between two stitches is a stitch end.
    order = sorted(pn.edges, key=lambda x: x.start)
    a, b = order[0], order[1]
    with pytest.raises(PatternError, match=f"between edges {a.id} and {b.id} .outline vertex {b.start}. "
                                           "cannot be deleted: it is"):
        join_edges(base, pn.name, a.id, b.id)


def test_splits_and_joins_that_cannot_be_made_are_refused():
    base = load_pattern(PENCIL)
    pn = base.panels[0]
    e = pn.edges[0]
    with pytest.raises(PatternError, match="on an end of edge"):
        split_edge(base, pn.name, e.id, e.p0)
    with pytest.raises(PatternError, match="edge id .* is taken"):
        split_edge(base, pn.name, e.id, curves.evaluate(e, [0.5])[0], new_id=pn.edges[1].id)
    with pytest.raises(PatternError, match="has no edge 999"):
        split_edge(base, pn.name, 999, e.p0)
    order = sorted(pn.edges, key=lambda x: x.start)
    with pytest.raises(PatternError, match="does not start where"):
        join_edges(base, pn.name, order[0].id, order[2].id)
