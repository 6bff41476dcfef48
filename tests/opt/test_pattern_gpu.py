"""The pattern parametrization p(theta) and its adjoint on the GPU (seamfit._core.CudaPattern:
dense per-panel blocks of the interior update) against the CPU's sparse Cholesky solves, and
the fallback to the CPU when the blocks would not fit.

The GPU cases exist where a GPU is present (not collected elsewhere, rather than reported as
skipped); the refusal of an unknown device runs everywhere.
"""
from __future__ import annotations

import numpy as np
import pytest

import opt_synthetic as S
from seamfit.errors import SolveError
from seamfit.opt import Parametrization



@pytest.mark.gpu
def test_gpu_pattern_and_adjoint_match_the_cpu():
    m = S.two_panels(seed=3)
    cpu, gpu = Parametrization(m), Parametrization(m)
    assert gpu.use_device("cuda") == "cuda" and gpu.device == "cuda"
    rng = np.random.default_rng(2)
    for _ in range(3):
        theta = cpu.theta_bar * 1.03 + rng.normal(0, 0.01, cpu.theta_bar.shape)
        p, pg = cpu.pattern(theta), gpu.pattern(theta)
        assert np.abs(pg - p).max() <= 1e-13 * np.abs(p).max()
        g = rng.normal(size=p.shape)
        a, ag = cpu.adjoint(g), gpu.adjoint(g)
        assert np.abs(ag - a).max() <= 1e-13 * np.abs(a).max()
    assert np.array_equal(gpu.pattern(gpu.theta_bar), gpu.pattern(gpu.theta_bar))   # deterministic
    assert np.abs(gpu.pattern(gpu.theta_bar) - gpu.pbar).max() < 1e-15


@pytest.mark.gpu
def test_blocks_too_large_for_the_limit_stay_on_the_cpu(monkeypatch):
    m = S.two_panels()
    P = Parametrization(m)
    monkeypatch.setattr(Parametrization, "GPU_MAX_BYTES", 1024)
    assert P.use_device("cuda") == "cpu" and P.device == "cpu"
    assert "MiB of GPU memory" in P.device_note
    theta = P.theta_bar * 1.01
    assert np.abs(P.pattern(theta) - P._native.pattern(theta)).max() == 0


def test_unknown_device_is_refused():
    with pytest.raises(SolveError, match="unknown device .* for the parametrization"):
        Parametrization(S.two_panels()).use_device("tpu")
