"""The adjoint solve H lam = dF/dx on the GPU (preconditioned MINRES over the stored
Hessian blocks, seamfit._core.CudaAdjoint) against the CPU's direct LDL^T of the same
shifted matrix, at a real grading state: the sample pencil skirt graded from size 6
to size 10, its garment settled on the target body.

The GPU cases exist where a GPU is present (as in tests/opt/test_grade_device.py, not
collected elsewhere rather than reported as skipped); the refusal runs everywhere.
"""
from __future__ import annotations

import numpy as np
import pytest

from grading_helpers import settled_sample_grading
from seamfit._native import core
from seamfit.errors import DeviceError, SolveError
from seamfit.opt.adjoint import GPU_EQUILIBRIUM_BUDGET_FACTOR, AdjointSolver
from common import GPU



@pytest.fixture(scope="module")
def state():
    """The grading context (4 cm mesh, GPU simulations) and an exact target drape."""
    ctx, x = settled_sample_grading(4.0, "cuda")
    p = ctx.param.pattern(ctx.param.theta_bar)
    _, _, gx, gp = ctx.costs.evaluate(x, p)
    return ctx, x, np.asarray(gx, dtype=float), np.asarray(gp, dtype=float)


@pytest.mark.gpu
@pytest.mark.parametrize("psd", [False, True])
def test_gpu_adjoint_matches_the_direct_solve(state, psd):
    """lam solves the shifted system to the asked tolerance (checked with the CPU's
    own Hessian product), and the pattern gradient it gives matches the direct
    solve's to 1e-4 of its norm."""
    ctx, x, gx, gp = state
    cpu = AdjointSolver(ctx.sim, device="cpu", psd=psd)
    gpu = AdjointSolver(ctx.sim, device="cuda", psd=psd, gpu_tolerance=1e-8)
    cpu.factorize(x)
    gpu.factorize(x)
    lam_cpu = cpu.solve(gx)
    lam_gpu = gpu.solve(gx)
    rep = gpu.last_report
    assert rep["converged"], rep["message"]
    assert gpu.gpu_fallbacks == 0
    # The shift is the CPU's: eps * mean|diag H|.
    H = ctx.sim.hessian(x, psd=psd)
    shift = 1e-8 * float(np.mean(np.abs(H.diagonal())))
    assert rep["shift"] == pytest.approx(shift, rel=1e-9)
    # The true residual, with the CPU's Hessian.
    r = gx.reshape(-1) - (H @ lam_gpu + shift * lam_gpu)
    assert np.linalg.norm(r) <= 1e-6 * np.linalg.norm(gx), np.linalg.norm(r) / np.linalg.norm(gx)
    assert rep["residual"] == pytest.approx(np.linalg.norm(r) / np.linalg.norm(gx), rel=1e-2, abs=1e-12)
    g_cpu = gp + ctx.sim.dfdp_T(x, lam_cpu.reshape(-1, 3))
    g_gpu = gp + ctx.sim.dfdp_T(x, lam_gpu.reshape(-1, 3))
    err = np.linalg.norm(g_gpu - g_cpu) / np.linalg.norm(g_cpu)
    assert err <= 1e-4, err


@pytest.mark.gpu
def test_gpu_adjoint_warm_start_and_determinism(state):
    """A second solve starts from the last lam and needs (almost) no iterations; the
    same solve twice gives the same bits (sums in a fixed order)."""
    ctx, x, gx, gp = state
    gpu = AdjointSolver(ctx.sim, device="cuda")
    gpu.factorize(x)
    lam1 = gpu.solve(gx)
    cold = gpu.last_report["iterations"]
    assert cold > 0
    lam2 = gpu.solve(gx)
    assert gpu.last_report["iterations"] <= 1
    again = AdjointSolver(ctx.sim, device="cuda")
    again.factorize(x)
    assert np.array_equal(again.solve(gx), lam1)
    assert np.allclose(lam2, lam1, rtol=0, atol=1e-6 * np.abs(lam1).max())


@pytest.mark.gpu
def test_persistent_kernel_and_kernel_graph_agree(state):
    """The one-launch persistent MINRES and the graph of four kernels per iteration run the
    same recurrence (sums in another order): about the same iteration count, and pattern
    gradients equal to 1e-7 of their norm."""
    ctx, x, gx, gp = state
    gpu = ctx.sim.cuda()._gpu
    adj = core().CudaAdjoint(gpu)
    adj.set_state(gpu, x, False, 1e-8)
    lam_p, rep_p = adj.solve(gpu, gx, None, 1e-10, 20000, persistent=True)
    lam_g, rep_g = adj.solve(gpu, gx, None, 1e-10, 20000, persistent=False)
    assert rep_p["converged"] and rep_g["converged"]
    assert abs(rep_p["iterations"] - rep_g["iterations"]) <= max(5, rep_g["iterations"] // 100)
    g_p = gp + ctx.sim.dfdp_T(x, lam_p)
    g_g = gp + ctx.sim.dfdp_T(x, lam_g)
    assert np.linalg.norm(g_p - g_g) <= 1e-7 * np.linalg.norm(g_g)


@pytest.mark.gpu
def test_gpu_adjoint_out_of_budget_falls_back_to_the_direct_solve(state):
    """MINRES stopped by its iteration budget says so, and the gradient is then the
    CPU's direct solve: counted, never silently inexact."""
    ctx, x, gx, gp = state
    cpu = AdjointSolver(ctx.sim, device="cpu")
    gpu = AdjointSolver(ctx.sim, device="cuda", gpu_max_iterations=3)
    g_cpu = cpu.pattern_gradient(x, gx, gp)
    g_gpu = gpu.pattern_gradient(x, gx, gp)
    assert "iteration budget" in gpu.last_report["message"] and not gpu.last_report["converged"]
    # 3 iterations, then 9 more from there (GPU_EQUILIBRIUM_BUDGET_FACTOR budgets in all)
    assert gpu.last_report["iterations"] == 3 * (GPU_EQUILIBRIUM_BUDGET_FACTOR - 1)
    assert gpu.extended == 1 and gpu.gpu_fallbacks == 1
    assert np.allclose(g_gpu, g_cpu, rtol=1e-12, atol=1e-12 * np.abs(g_cpu).max())
    assert gpu.stats()["gpu_fallbacks"] == 1


@pytest.mark.gpu
def test_an_equilibrium_solve_goes_on_past_the_budget_before_the_cpu(state):
    """At an equilibrium state a solve stopped by the budget continues from its iterate
    (no CPU factorization when the longer run converges); at an inexact state it does not."""
    ctx, x, gx, gp = state
    probe = AdjointSolver(ctx.sim, device="cuda")
    probe.pattern_gradient(x, gx, gp)
    n = probe.last_report["iterations"]
    assert n >= 20
    budget = (n + GPU_EQUILIBRIUM_BUDGET_FACTOR - 1) // (GPU_EQUILIBRIUM_BUDGET_FACTOR - 1)
    gpu = AdjointSolver(ctx.sim, device="cuda", gpu_max_iterations=budget,
                        equilibrium_tolerance=10 * ctx.exact_tolerance)
    g = gpu.pattern_gradient(x, gx, gp, residual=0.0)
    assert gpu.extended == 1 and gpu.gpu_fallbacks == 0 and gpu.last_report["converged"]
    g_ref = probe.pattern_gradient(x, gx, gp)
    assert np.linalg.norm(g - g_ref) <= 1e-6 * np.linalg.norm(g_ref)
    gpu.pattern_gradient(x, gx, gp, residual=1.0)   # inexact: kept at the budget
    assert gpu.extended == 1 and gpu.truncated <= 1 and gpu.gpu_fallbacks == 0


@pytest.mark.gpu
def test_inexact_forcing_relaxes_the_tolerance_at_inexact_states_only(state):
    """At an inexact state (residual r above the equilibrium tolerance) MINRES stops at
    max(1e-8, forcing * r); at the settled state the tolerance stays 1e-8."""
    ctx, x, gx, gp = state
    x_inexact = ctx.sim.solve(ctx.xtilde, max_iterations=8, device="cuda").x
    r = ctx.sim.residual(x_inexact)
    assert r > 10 * ctx.exact_tolerance
    tight = AdjointSolver(ctx.sim, device="cuda", equilibrium_tolerance=10 * ctx.exact_tolerance)
    loose = AdjointSolver(ctx.sim, device="cuda", equilibrium_tolerance=10 * ctx.exact_tolerance,
                          inexact_forcing=0.01)
    tight.pattern_gradient(x_inexact, gx, gp)
    loose.pattern_gradient(x_inexact, gx, gp)
    assert loose.relaxed == 1 and tight.relaxed == 0
    assert loose.last_report["converged"] and loose.last_report["estimate"] <= 0.01 * r
    assert loose.minres_iterations < tight.minres_iterations
    loose.pattern_gradient(x, gx, gp)  # settled: no relaxation
    assert loose.relaxed == 1 and loose.last_report["estimate"] <= 1e-8


def test_cuda_adjoint_without_a_gpu_fails_clearly():
    """Asking for the GPU adjoint where there is none raises DeviceError with the reason."""
    from seamfit.sim import Fabric, SimSettings, Simulator

    from sim_helpers import flat_sheet
    with pytest.raises(SolveError, match="unknown device .* for the adjoint"):
        AdjointSolver(None, device="tpu")
    if GPU:
        return
    mesh = flat_sheet(4, 4)
    sim = Simulator(mesh, None, Fabric(), SimSettings())
    adj = AdjointSolver(sim, device="cuda")
    with pytest.raises(DeviceError, match="cuda|CUDA"):
        adj.factorize(mesh.x0)
