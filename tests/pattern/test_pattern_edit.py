"""seamfit.pattern.edit: new edge curves, outline sampled again, indices following their edges."""
import copy

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import curves, load_pattern, validate_pattern
from seamfit.pattern.edit import arc_through, cubic_through, edges_in_order, edit_edges
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
PENCIL = PATTERNS / "gc_pencil_skirt" / "size06" / "pattern.json"
CIRCLE = PATTERNS / "gc_circle_skirt" / "size06" / "pattern.json"


def _node_edges(pattern):
    """Each stitch side as the ids of the edges starting at its two ends."""
    def at(panel, i):
        return next(e.id for e in panel.edges if e.start == i)
    return [(sd.panel, at(pattern.panel(sd.panel), sd.range[0]), at(pattern.panel(sd.panel), sd.range[1]))
            for s in pattern.stitches for sd in (s.a, s.b)]


def test_a_longer_edge_gets_more_points_and_everything_follows():
    base = load_pattern(PENCIL)
    keep = copy.deepcopy(base)
    pn = next(p for p in base.panels if any(e.kind == "line" for e in p.edges))
    e = max((x for x in pn.edges if x.kind == "line"), key=curves.length)
    bent = copy.deepcopy(e)
    mid = 0.5 * (np.array(e.p0) + np.array(e.p1))
    normal = np.array([e.p0[1] - e.p1[1], e.p1[0] - e.p0[0]]) / curves.length(e)
    bent.kind, bent.ctrl = "quadratic", [tuple(mid + 0.3 * curves.length(e) * normal)]
    out = edit_edges(base, {pn.name: {e.id: bent}})
    op = out.panel(pn.name)
    ne = next(x for x in op.edges if x.id == e.id)
    assert ne.kind == "quadratic" and ne.length_cm == pytest.approx(curves.length(bent), abs=1e-4)
    assert op.n_vertices > pn.n_vertices
    idx = (ne.start + np.arange((ne.end - ne.start) % op.n_vertices + 1)) % op.n_vertices
    assert np.linalg.norm(np.diff(op.outline_cm[idx], axis=0), axis=1).max() <= 1.0 + 1e-9
    assert curves.distance_to_curve(ne, op.outline_cm[idx[:-1]]).max() < 1e-5     # its own precision
    # Every other edge keeps its outline points; nodes, corners, landmarks and stitches follow.
    for old in pn.edges:
        new = next(x for x in op.edges if x.id == old.id)
        if old.id != e.id:
            m = (old.end - old.start) % pn.n_vertices
            assert np.array_equal(op.outline_cm[(new.start + np.arange(m)) % op.n_vertices],
                                  pn.outline_cm[(old.start + np.arange(m)) % pn.n_vertices])
    starts = {x.id: x.start for x in op.edges}
    assert sorted(op.nodes) == sorted(starts.values())
    assert sorted(op.corners) == sorted(starts[x.id] for x in pn.edges if x.start in pn.corners)
    assert _node_edges(out) == _node_edges(base)
    assert validate_pattern(out).ok
    # The input is not modified.
    from seamfit.pattern.sewpat import pattern_to_dict
    assert pattern_to_dict(base) == pattern_to_dict(keep)


def test_arcs_and_cubics_are_fitted_through_their_ends():
    pattern = load_pattern(CIRCLE)
    arc = next(e for p in pattern.panels for e in p.edges if e.kind == "arc")
    pts = curves.evaluate(arc, np.linspace(0, 1, 40))[1:-1]
    fitted, dev = arc_through(arc.p0, arc.p1, pts)
    assert dev < 1e-9
    assert fitted["radius"] == pytest.approx(arc.arc["radius"], rel=1e-12)
    assert fitted["angle1_rad"] - fitted["angle0_rad"] == pytest.approx(
        arc.arc["angle1_rad"] - arc.arc["angle0_rad"], abs=1e-12)
    # An S curve over the same ends: no arc, and the cubic found again (from its own
    # parameters exactly, from chord lengths within the 0.5 mm an edited arc is held to).
    p0, p1 = np.array(arc.p0), np.array(arc.p1)
    span = float(np.linalg.norm(p1 - p0))
    normal = np.array([p0[1] - p1[1], p1[0] - p0[0]]) / span
    cubic = copy.deepcopy(arc)
    cubic.kind, cubic.arc = "cubic", None
    cubic.ctrl = [tuple(p0 + (p1 - p0) / 3 + 0.3 * span * normal), tuple(p0 + 2 * (p1 - p0) / 3 - 0.2 * span * normal)]
    t = np.linspace(0, 1, 40)[1:-1]
    pts = curves.evaluate(cubic, t)
    assert arc_through(p0, p1, pts)[1] > 1.0
    ctrl, dev = cubic_through(p0, p1, pts, t)
    assert dev < 1e-4 and np.allclose(ctrl, cubic.ctrl, atol=1e-6)
    assert cubic_through(p0, p1, pts)[1] < 0.05


def test_edges_that_do_not_run_around_the_outline_are_refused():
    pn = load_pattern(PENCIL).panels[0]
    pn.edges = pn.edges[1:]
    with pytest.raises(PatternError, match="do not run end to start"):
        edges_in_order(pn, f"panel {pn.name!r}")
