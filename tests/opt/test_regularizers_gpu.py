"""R^fix + R^cur, R^seam and the preconditioner P^-1 g on the GPU (seamfit._core.CudaRegularizers,
CudaSeamLength: the CPU's element functions, P^-1 dense) against the CPU, P^-1 following
set_strengths and add_to_preconditioner, and the fallback to the CPU when P^-1 would not fit.

The GPU cases exist where a GPU is present (not collected elsewhere, rather than reported as
skipped); the fallback, which is decided before a device is asked for, and the refusal of an
unknown device run everywhere.
"""
from __future__ import annotations


import numpy as np
import pytest

from seamfit.errors import SolveError
from seamfit.mesh import build_sewn_mesh
from seamfit.opt import Regularizers, SeamLength
from seamfit.pattern import load_pattern
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"


@pytest.fixture(scope="module")
def mesh():
    # 10K triangles, 674 boundary entries: three blocks of the reductions, a 14 MiB P^-1.
    return build_sewn_mesh(load_pattern(PATTERN), edge_length_cm=1.1)


def rel(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(np.asarray(b)).max(), 1e-300))


def moved(param, rng, mm=5.0):
    return param.theta_bar * 1.02 + 1e-3 * mm * rng.normal(size=param.theta_bar.shape)


def pair(param, fix=100.0, cur=1e6, **kw):
    cpu, gpu = Regularizers(param, fix, cur, **kw), Regularizers(param, fix, cur, **kw)
    assert gpu.use_device("cuda") == "cuda" and gpu.device == "cuda" and gpu.device_note == ""
    return cpu, gpu


@pytest.mark.gpu
def test_gpu_regularizers_match_the_cpu(param):
    rng = np.random.default_rng(1)
    for kw in ({}, {"objective_fix": 0.0}, {"objective_fix": 30.0}):
        cpu, gpu = pair(param, **kw)
        for _ in range(3):
            theta = moved(param, rng)
            v, t, g = cpu.evaluate(theta)
            vg, tg, gg = gpu.evaluate(theta)
            assert abs(vg - v) <= 1e-12 * abs(v)
            for k in ("fix", "cur"):
                assert abs(tg[k] - t[k]) <= 1e-12 * abs(v), k
            assert gg.shape == g.shape and rel(gg, g) <= 1e-12
        # Deterministic: block partials summed in a fixed order, gradients gathered in slot order.
        a, b = gpu.evaluate(theta), gpu.evaluate(theta)
        assert a[0] == b[0] and a[1] == b[1] and np.array_equal(a[2], b[2])
    # Zero at the base pattern, either term switched off.
    cpu, gpu = pair(param, fix=1.0, cur=0.0)
    v, _, g = gpu.evaluate(param.theta_bar)
    assert v == 0 and np.abs(g).max() == 0
    theta = moved(param, rng)
    assert rel(gpu.evaluate(theta)[2], cpu.evaluate(theta)[2]) <= 1e-12


@pytest.mark.gpu
def test_gpu_seam_matches_the_cpu(mesh, param):
    rng = np.random.default_rng(2)
    cpu, gpu = SeamLength(param, mesh, 1e6), SeamLength(param, mesh, 1e6)
    assert gpu.use_device("cuda") == "cuda" and gpu.device == "cuda"
    v0, g0 = gpu.evaluate(param.theta_bar)
    assert v0 < 1e-20 and np.abs(g0).max() < 1e-9
    for _ in range(3):
        theta = moved(param, rng)
        v, g = cpu.evaluate(theta)
        vg, gg = gpu.evaluate(theta)
        assert abs(vg - v) <= 1e-12 * abs(v)
        assert gg.shape == g.shape and rel(gg, g) <= 1e-12
    a, b = gpu.evaluate(theta), gpu.evaluate(theta)
    assert a[0] == b[0] and np.array_equal(a[1], b[1])
    assert gpu.evaluations == 6   # the GPU's evaluations count as the CPU's do
    gpu.set_strength(3e5)          # read from the CPU object at each call
    cpu.set_strength(3e5)
    assert abs(gpu.evaluate(theta)[0] - cpu.evaluate(theta)[0]) <= 1e-12 * cpu.evaluate(theta)[0]


def check_preconditioner(cpu, gpu, rng, n=3):
    """GPU P^-1 g against the CPU's Cholesky solve, and P (P^-1 g) = g."""
    P = cpu.hessian()
    for _ in range(n):
        g = rng.normal(size=(cpu.param.n_theta, 2)) * 1e3
        x, xg = cpu.apply_preconditioner(g), gpu.apply_preconditioner(g)
        assert xg.shape == x.shape
        # Two ways of rounding the same solve: the dense inverse and the triangular solves.
        assert rel(xg, x) <= 1e-9, rel(xg, x)
        assert rel((P @ xg.ravel()).reshape(-1, 2), g) <= 1e-9


@pytest.mark.gpu
def test_gpu_preconditioner_matches_the_cpu(mesh, param):
    rng = np.random.default_rng(3)
    seam = SeamLength(param, mesh, 1e6)
    for kw in ({}, {"objective_fix": 0.0}):
        cpu, gpu = pair(param, **kw)
        for r in (cpu, gpu):
            r.add_to_preconditioner(seam.gauss_newton())
        check_preconditioner(cpu, gpu, rng)
        g = rng.normal(size=(param.n_theta, 2))
        assert np.array_equal(gpu.apply_preconditioner(g), gpu.apply_preconditioner(g))   # deterministic
        assert gpu._gpu.inverse_builds == 1   # P constant: one inverse
        assert gpu._gpu.device_bytes >= 8 * (2 * param.n_theta) ** 2


@pytest.mark.gpu
def test_gpu_preconditioner_follows_strengths_and_extra_block(mesh, param):
    rng = np.random.default_rng(4)
    cpu, gpu = pair(param)
    check_preconditioner(cpu, gpu, rng, n=1)
    builds = gpu._gpu.inverse_builds
    for r in (cpu, gpu):
        r.set_strengths(40.0, 3e5)
    check_preconditioner(cpu, gpu, rng, n=1)
    assert gpu._gpu.inverse_builds == builds + 1
    theta = moved(param, rng)   # the objective's strengths follow too
    assert rel(gpu.evaluate(theta)[2], cpu.evaluate(theta)[2]) <= 1e-12
    H = SeamLength(param, mesh, 1e6).gauss_newton()
    for r in (cpu, gpu):
        r.add_to_preconditioner(H)
    check_preconditioner(cpu, gpu, rng, n=1)
    assert gpu._gpu.inverse_builds == builds + 2
    for r in (cpu, gpu):
        r.add_to_preconditioner(None)
    check_preconditioner(cpu, gpu, rng, n=1)
    assert gpu._gpu.inverse_builds == builds + 3
    for r in (cpu, gpu):
        r.set_strengths(40.0, 3e5)   # unchanged: P^-1 is kept
    check_preconditioner(cpu, gpu, rng, n=1)
    assert gpu._gpu.inverse_builds == builds + 3


@pytest.mark.gpu
def test_gpu_preconditioner_needs_delta_fix(param):
    _, gpu = pair(param, fix=0.0)
    with pytest.raises(ValueError, match="delta_fix > 0"):
        gpu.apply_preconditioner(np.ones((param.n_theta, 2)))


@pytest.mark.gpu
def test_gpu_shapes_are_checked(mesh, param):
    _, gpu = pair(param)
    with pytest.raises(ValueError, match="theta"):
        gpu.evaluate(np.zeros((param.n_theta + 1, 2)))
    seam = SeamLength(param, mesh, 1.0)
    seam.use_device("cuda")
    with pytest.raises(ValueError, match="theta"):
        seam.evaluate(np.zeros((param.n_theta - 1, 2)))


def test_inverse_too_large_for_the_limit_stays_on_the_cpu(param, monkeypatch):
    cpu, regs = Regularizers(param, 100.0, 1e6), Regularizers(param, 100.0, 1e6)
    monkeypatch.setattr(Regularizers, "GPU_MAX_BYTES", 1024)
    assert regs.use_device("cuda") == "cpu" and regs.device == "cpu"
    assert "P^-1 needs" in regs.device_note and "MiB of GPU memory" in regs.device_note
    rng = np.random.default_rng(5)
    theta, g = moved(param, rng), rng.normal(size=(param.n_theta, 2))
    assert regs.evaluate(theta)[0] == cpu.evaluate(theta)[0]
    assert np.array_equal(regs.apply_preconditioner(g), cpu.apply_preconditioner(g))
    assert regs.use_device("cpu") == "cpu" and regs.device_note == ""


def test_unknown_device_is_refused(mesh, param):
    with pytest.raises(SolveError, match="unknown device .* for the regularizers"):
        Regularizers(param, 1.0, 1.0).use_device("tpu")
    with pytest.raises(SolveError, match="unknown device .* for the seam-length term"):
        SeamLength(param, mesh, 1.0).use_device("tpu")
    assert Regularizers(param, 1.0, 1.0).use_device("cpu") == "cpu"
    assert SeamLength(param, mesh, 1.0).use_device("cpu") == "cpu"
