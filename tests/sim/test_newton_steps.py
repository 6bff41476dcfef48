"""Newton with an outside solver for its steps (inexact Newton): the CPU's Newton loop
(line search, barrier-safe steps) with each system H dx = f solved approximately, to an
Eisenstat-Walker forcing term, instead of by the sparse LDL^T. On the GPU the steps are
MINRES over the stored Hessian blocks (seamfit.sim.cuda.CudaSimulator.newton), which is
what the drape's polish uses there. On the CPU the same loop is driven here through
Simulator.solve(..., step=...) by the MINRES recurrence the GPU runs (_core.minres_solve).

The GPU case exists where a GPU is present (not collected elsewhere, rather than reported
as skipped).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from seamfit._native import core
from test_minres import psd_block_inverses
from test_sim_cuda import sheet_on_ball

TOL = 1e-5


def minres_step(sim, log=None, max_it=5000):
    """step(x, psd, shift, f, forcing): MINRES on (H + shift * mean|diag H|) dx = f with the
    block-Jacobi preconditioner of the GPU's solve."""
    def step(x, psd, shift, f, forcing):
        H = sim.hessian(x, psd=psd).tocsr()
        A = (H + shift * np.mean(np.abs(H.diagonal())) * sp.identity(H.shape[0])).tocsr()
        dx, rep = core().minres_solve(A.indptr.astype(np.int32), A.indices.astype(np.int32), A.data,
                                      psd_block_inverses(sim, x, shift), f.ravel(), np.zeros(f.size), forcing,
                                      max_it)
        if log is not None:
            log.append({"psd": psd, "shift": shift, "forcing": forcing, "iterations": rep["iterations"]})
        return dx, rep["iterations"]
    return step


def newton(sim, step=None, tol=TOL, iterations=200):
    st = sim._settings(tol, iterations, "newton")
    return sim.core.solve(sim._start(None), st, None, step)


def test_inexact_newton_reaches_the_direct_newton_equilibrium():
    """Same equilibrium as Newton with LDL^T, to 0.001 mm, with contact against a ball;
    the forcing terms stay within (0, 0.1] and no looser than the tolerance needs."""
    sim = sheet_on_ball("cpu", TOL)
    x_ref, ref = newton(sim)
    log = []
    x, rep = newton(sim, minres_step(sim, log))
    assert ref["converged"] and rep["converged"], (ref["message"], rep["message"])
    assert rep["residual"] <= TOL and sim.residual(x) == pytest.approx(rep["residual"], rel=1e-9)
    assert np.abs(x - x_ref).max() <= 1e-6
    assert rep["linear_iterations"] == sum(e["iterations"] for e in log) > 0
    forcing = np.array([e["forcing"] for e in log])
    assert forcing[0] == pytest.approx(0.1) and np.all(forcing <= 0.1 + 1e-15) and np.all(forcing > 0)
    # the exact Hessian while its steps are accepted, as the direct solve does
    assert any(not e["psd"] for e in log)
    e0, _ = sim.energy(sim._start(None))
    assert rep["energy"] < e0
    assert np.min(sim.phi(x)) > 0  # nothing inside the ball


def test_a_step_that_climbs_is_solved_again_tighter():
    """An inexact step need not descend: when the line search fails on it, the same
    Newton iteration is solved again with a forcing term 100x tighter and a larger shift,
    and the solve goes on to convergence."""
    sim = sheet_on_ball("cpu", TOL)
    log = []
    inner = minres_step(sim, log)
    calls = [0]

    def climbing_first(x, psd, shift, f, forcing):
        calls[0] += 1
        dx, k = inner(x, psd, shift, f, forcing)
        if calls[0] == 1 and np.dot(f.ravel(), dx) > 0:
            dx = -dx  # uphill along the force
        return dx, k

    x, rep = newton(sim, climbing_first)
    assert rep["converged"], rep["message"]
    assert log[1]["forcing"] == pytest.approx(log[0]["forcing"] / 100)
    assert log[1]["shift"] > log[0]["shift"] and log[1]["psd"]


def test_a_failing_step_solver_stops_with_a_clear_message():
    sim = sheet_on_ball("cpu", TOL)
    x0 = sim._start(None)
    x, rep = newton(sim, lambda x, psd, shift, f, forcing: None)
    assert not rep["converged"] and "linear solve of the Newton step failed" in rep["message"]
    assert np.all(np.isfinite(x)) and np.min(sim.phi(x)) > 0
    assert np.array_equal(x, sim.project_outside(x0)[0])  # the start, projected out of the ball


@pytest.mark.gpu
def test_gpu_newton_matches_the_cpu():
    """The GPU's inexact Newton (MINRES steps on the device, line search on the CPU)
    reaches the equilibrium of the CPU's direct Newton, and a drape's polish stage on the
    GPU uses it."""
    sim = sheet_on_ball("cuda", TOL)
    x_ref, ref = newton(sim)
    x, rep = sim.cuda().newton(sim._start(None), settings=sim._settings(TOL, 200, "newton"))
    assert ref["converged"] and rep["converged"], (ref["message"], rep["message"])
    assert np.abs(x - x_ref).max() <= 1e-6
    assert rep["linear_iterations"] > 0 and rep["device"]
    res = sim.drape(polish=True)
    polish = [s for s in res.stages if s["stage"] == "polish"]
    assert all(s["linear_iterations"] > 0 for s in polish)
