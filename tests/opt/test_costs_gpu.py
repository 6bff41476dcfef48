"""The fitting costs and their gradients on the GPU (seamfit._core.CudaCostSet, the
same element functions as the CPU's CostSet) against the CPU, term by term and all
together, and a zero strength never evaluated there either.

The GPU cases exist where a GPU is present (not collected elsewhere, rather than
reported as skipped); the refusal of an unknown device runs everywhere.
"""
from __future__ import annotations

import numpy as np
import pytest

from seamfit.errors import SolveError
from seamfit.opt import Parametrization
from test_opt_costs import garment, make_costs, mesh  # noqa: F401  (fixtures)



@pytest.mark.gpu
@pytest.mark.parametrize("strengths", [dict(dis=3.0), dict(pos=2.0), dict(str=5.0), dict(smo=0.5),
                                       dict(dis=3.0, pos=2.0, str=5.0, smo=0.5)])
def test_gpu_costs_match_the_cpu(mesh, garment, strengths):  # noqa: F811
    cpu = make_costs(mesh, garment, **strengths)
    gpu = make_costs(mesh, garment, **strengths)
    gpu.use_device("cuda")
    assert gpu.device == "cuda"
    pbar = Parametrization(mesh).pbar
    p = 1.02 * pbar + np.random.default_rng(3).normal(0, 1e-3, pbar.shape)
    v, terms, gx, gp = cpu.evaluate(garment["x"], p)
    vg, terms_g, gxg, gpg = gpu.evaluate(garment["x"], p)
    assert vg == pytest.approx(v, rel=1e-12)
    for k in terms:
        assert terms_g[k] == pytest.approx(terms[k], rel=1e-12, abs=0.0)
    assert np.abs(gxg - gx).max() <= 1e-12 * max(np.abs(gx).max(), 1e-300)
    assert np.abs(gpg - gp).max() <= 1e-12 * max(np.abs(gp).max(), 1e-300)
    # a term with zero strength is never evaluated, on either device
    assert gpu.evaluations == cpu.evaluations
    assert all(gpu.evaluations[k] == (1 if strengths.get(k, 0) else 0) for k in terms)


def test_unknown_cost_device_is_refused(mesh, garment):  # noqa: F811
    with pytest.raises(SolveError, match="unknown device .* for the cost set"):
        make_costs(mesh, garment, str=1.0).use_device("tpu")
