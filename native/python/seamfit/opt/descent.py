"""The outer loop of Algorithm 1, for any objective (the grading f, or the positional
cost alone for the two-phase baseline):

    loop:  theta <- theta - s P^-1 Grad(x, theta)          Eq. 18-19 (adjoint)
           every M iterations an exact simulation; if the objective rose since the
           last exact checkpoint: go back there, double S, halve s ("long-range
           backtracking"); otherwise halve S (not below S_min) and grow s
           else x <- S simulation iterations from the previous x (inexact)

The result is always an exact checkpoint, so its objective is that of a converged
drape, and it never ends higher than the checkpoint before it.

On the GPU (simulator and adjoint on device "cuda") theta and x live in GPU memory
(seamfit.device_arrays) from one exact checkpoint to the next: an inexact outer
iteration moves only scalars to the host. They come down for the checkpoint's exact
solve, whose result is kept on the host, and go back up after it.
"""
from __future__ import annotations

import time

import numpy as np

from ..device_arrays import host, to_device
from .output import SearchOutcome


def state_on_gpu(ctx) -> bool:
    """Whether the search's state stays on the GPU: its simulator and adjoint run there
    (the other pieces take GPU arrays on either device)."""
    return ctx.adjoint.device == "cuda" and ctx.sim.settings.device == "cuda"


# Real gradings start at objectives of order 1 to 1e3; one this small is floating-point
# noise on an exact fit.
OBJECTIVE_ROUNDOFF = 1e-12

# The loop's own step control (the solver's, not a user's: docs/optimizer.md).
STEP = 1.0                 # s at the start: a step along -P^-1 grad
MAX_MOVE_MM = 1.0          # trust region at s = 1: no boundary vertex moves more per iteration
STEP_GROWTH = 1.5          # s grows by this after an accepted checkpoint ...
MAX_STEP = 16.0            # ... up to this
MIN_STEP = 1e-4            # backtracking below this step: converged, nothing decreases f
MAX_INNER_ITERATIONS = 512  # S doubles on a backtrack up to this
REL_TOL = 1e-3             # stop when a checkpoint lowers f by less than REL_TOL * f


def descend(ctx, objective, theta0, x0, *, label: str = "optimize") -> SearchOutcome:
    """Algorithm 1's loop on ``objective`` (an ``Objective``) from the exact drape x0 of
    theta0. Checkpoints record both the searched objective and the grading f."""
    settings = ctx.settings
    regs, sim, param = ctx.regs, ctx.sim, ctx.param
    hist: dict[str, list] = {"iteration": [], "objective": [], "seconds": [], "exact": [], "S": [], "step": []}
    t_loop = time.perf_counter()
    theta, x = np.array(theta0, dtype=float), np.array(x0, dtype=float)
    f0, _ = objective.objective(x, theta)
    ck_theta, ck_x, ck_f = theta.copy(), x.copy(), f0
    ck_p = np.array(host(param.pattern(theta)), dtype=float) if settings.stop_move_mm > 0 else None
    # The relative residual of x as its solve reported it (the adjoint's tolerance
    # follows it on the GPU): x0 is an exact drape.
    x_res = ck_res = None
    same = objective is ctx.objective

    def grading_f(xx, th, f_search):
        return f_search if same else ctx.objective.objective(xx, th)[0]

    checkpoints = [(0, f0, grading_f(x, theta, f0), None)]
    S, s = settings.inner_iterations, STEP
    k = 0              # accepted outer iterations
    work = 0           # outer iterations done, discarded ones included
    backtracks, converged, message = 0, False, "iteration limit"

    def record(f, exact_flag):
        hist["iteration"].append(work)
        hist["objective"].append(f)
        hist["seconds"].append(time.perf_counter() - t_loop)
        hist["exact"].append(exact_flag)
        hist["S"].append(S)
        hist["step"].append(s)

    # Where the loop's time goes: simulation (inexact steps and exact checkpoints, on
    # the simulator's device), gradient (costs, adjoint solve, df/dp) and the rest.
    split = {"simulation": 0.0, "gradient": 0.0, "objective": 0.0}
    record(f0, True)
    # The state the outer iterations work on: x and theta themselves, or their GPU copies.
    gpu = state_on_gpu(ctx)
    x_w, theta_w = (to_device(x), to_device(theta)) if gpu else (x, theta)
    max_work = 4 * settings.max_outer_iterations
    if f0 <= OBJECTIVE_ROUNDOFF:
        # Nothing to fit (the target body is the base body): every checkpoint would differ
        # from the start by round-off alone and be backtracked until the budget ran out.
        converged, message, max_work = True, "the start already fits (objective at round-off)", 0
    while k < settings.max_outer_iterations and work < max_work:
        t_part = time.perf_counter()
        f_cur, g = objective.gradient(x_w, theta_w, residual=x_res)
        split["gradient"] += time.perf_counter() - t_part
        pg = regs.apply_preconditioner(g)  # the step goes along -P^-1 g
        # The preconditioner fixes the direction's shape, not its scale: cap the move
        # so an inexact state far from equilibrium cannot throw the pattern away.
        # The trust radius shrinks and grows with s, so backtracking really shortens steps.
        dmax = pg.max_abs() if gpu else (float(np.max(np.abs(pg))) if pg.size else 0.0)
        step = s if dmax == 0 else s * min(1.0, 1e-3 * MAX_MOVE_MM / dmax)
        if gpu:
            theta_w.axpy(-step, pg)
        else:
            theta = theta_w = theta - step * pg
        k += 1
        work += 1
        sim.set_pattern(param.pattern(theta_w))
        at_checkpoint = (k % settings.checkpoint_every == 0) or k == settings.max_outer_iterations
        if not at_checkpoint:
            t_part = time.perf_counter()
            x_w, rep = sim.iterate(x_w, S)
            x_res = float(rep["residual"])
            split["simulation"] += time.perf_counter() - t_part
            record(f_cur, False)
            ctx.tell(stage=label, iteration=k, objective=f_cur, exact=False)
            if settings.time_budget_s and time.perf_counter() - ctx.t_start > settings.time_budget_s:
                at_checkpoint = True
            else:
                continue
        if gpu:
            theta, x = theta_w.numpy(), x_w.numpy()
        else:
            x = x_w
        t_part = time.perf_counter()
        res = ctx.exact(theta, x, "checkpoint")
        t_obj = time.perf_counter()
        split["simulation"] += t_obj - t_part
        f, f_terms = objective.objective(res.x, theta)
        split["objective"] += time.perf_counter() - t_obj
        sim_state = {"converged": res.converged, "residual": res.residual,
                     "max_sewing_gap_mm": res.max_sewing_gap_mm, "min_phi_mm": res.min_phi_mm, "terms": f_terms}
        if not (np.isfinite(f) and f <= ck_f):
            # Long-range backtracking: back to the last exact state, simulate more
            # accurately and take shorter steps.
            backtracks += 1
            k = (k - 1) // settings.checkpoint_every * settings.checkpoint_every
            theta, x, x_res = ck_theta.copy(), ck_x.copy(), ck_res
            theta_w, x_w = _restart(gpu, theta_w, x_w, theta, x)
            sim.set_pattern(param.pattern(theta))
            S = min(2 * S, MAX_INNER_ITERATIONS)
            s *= 0.5
            record(f, True)
            ctx.tell(stage=label, iteration=k, objective=f, exact=True, backtrack=True, state=sim_state)
            if s < MIN_STEP:
                converged, message = True, "no further decrease at the smallest step"
                break
            continue
        decrease = ck_f - f
        # how far the pattern moved since the last accepted checkpoint (mm)
        moved_mm = np.inf
        if settings.stop_move_mm > 0:
            p_new = np.array(host(param.pattern(theta)), dtype=float)
            moved_mm, ck_p = 1e3 * float(np.max(np.abs(p_new - ck_p))), p_new
        ck_theta, ck_x, ck_f, ck_res = theta.copy(), res.x.copy(), f, float(res.residual)
        checkpoints.append((k, f, grading_f(res.x, theta, f), None if np.isinf(moved_mm) else moved_mm))
        x, x_res = res.x, ck_res
        theta_w, x_w = _restart(gpu, theta_w, x_w, theta, x)
        record(f, True)
        # theta and x of the accepted checkpoint, for callers that follow the search (the
        # time-against-error benchmark); references, not copies.
        ctx.tell(stage=label, iteration=k, objective=f, exact=True, state=sim_state, theta=ck_theta, x=ck_x)
        S = max(S // 2, settings.min_inner_iterations)
        s = min(s * STEP_GROWTH, MAX_STEP)
        if decrease <= REL_TOL * abs(f):
            converged, message = True, "objective no longer falls"
            break
        if moved_mm <= settings.stop_move_mm:
            converged, message = True, f"the pattern stopped moving ({moved_mm:.3f} mm since the last checkpoint)"
            break
        if settings.time_budget_s and time.perf_counter() - ctx.t_start > settings.time_budget_s:
            message = "time budget reached"
            break

    return SearchOutcome(
        theta=ck_theta, x=ck_x, theta_start=np.array(theta0, dtype=float), x_start=np.array(x0, dtype=float),
        iterations=k, iterations_done=work, backtracks=backtracks, converged=converged, message=message,
        checkpoints=[{"iteration": i, "objective": float(fg), "search_objective": float(fs),
                      "moved_mm": mv} for i, fs, fg, mv in checkpoints],
        cost_evaluations=dict(objective.evaluations), history=hist,
        seconds_loop=time.perf_counter() - t_loop,
        details={"state_on_gpu": gpu, "seconds_loop_split": {**split, "factorizations": ctx.adjoint.seconds_factorize,
                                        "adjoint_solves": ctx.adjoint.seconds_solve},
                 "adjoint": ctx.adjoint.stats()})


def _restart(gpu: bool, theta_w, x_w, theta, x):
    """The working state after a checkpoint: (theta, x) from the host, on the GPU in
    the same buffers."""
    if not gpu:
        return theta, x
    theta_w.upload(np.ascontiguousarray(theta, dtype=float))
    x_w.upload(np.ascontiguousarray(x, dtype=float))
    return theta_w, x_w
