"""The drafted pattern put on the base pattern's mesh (tests/benchmarks/draft_on_mesh.py),
which the accuracy and objective-alignment benchmarks drape to read a draft's own ease:
the base itself comes back unchanged, and another size's draft lands on that draft's
outline with its panels' boundary lengths."""
from __future__ import annotations

import sys

import numpy as np
import pytest
from common import BENCHMARKS, SAMPLES

sys.path.insert(0, str(BENCHMARKS))
from draft_on_mesh import truth_on_mesh  # noqa: E402

from seamfit.mesh import build_sewn_mesh  # noqa: E402
from seamfit.opt.parametrization import Parametrization  # noqa: E402
from seamfit.pattern import load_pattern  # noqa: E402

PATTERNS = SAMPLES / "patterns"


def _perimeter(outline_cm) -> float:
    o = np.asarray(outline_cm, dtype=float)
    return float(np.sum(np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1)))


@pytest.fixture(scope="module")
def skirt():
    base = load_pattern(PATTERNS / "gc_pencil_skirt" / "size06" / "pattern.json")
    mesh = build_sewn_mesh(base, edge_length_cm=4.0)
    return base, mesh, Parametrization(mesh)


def test_the_base_on_its_own_mesh_is_lossless(skirt):
    base, mesh, param = skirt
    theta = truth_on_mesh(mesh, param, base, base)
    uv = 100.0 * param.pattern(theta)
    b = param.boundary_ids
    assert np.max(np.abs(uv[b] - np.asarray(mesh.uv_cm)[b])) < 1e-6


def test_another_size_lands_on_its_draft(skirt):
    base, mesh, param = skirt
    draft = load_pattern(PATTERNS / "gc_pencil_skirt" / "size10" / "pattern.json")
    uv = 100.0 * param.pattern(truth_on_mesh(mesh, param, base, draft))
    vp = np.asarray(mesh.vertex_panel)
    for k, name in enumerate(mesh.panel_names):
        ids = param.boundary_ids[vp[param.boundary_ids] == k]
        loop = next(lp for lp in mesh.boundary_loops if vp[lp[0]] == k)
        placed = _perimeter(uv[loop])
        # the boundary follows the draft's outline: its perimeter within the chords' shortfall
        drafted = _perimeter(draft.panel(name).outline_cm)
        assert placed == pytest.approx(drafted, rel=0.01), name
        assert placed != pytest.approx(_perimeter(base.panel(name).outline_cm), rel=1e-3), name
        assert len(ids) == len(loop)
