"""Baselines for comparison with Algorithm 1 (``GradeSettings.method``).

two-phase (paper Section 3, Fig. 2): phase 1's garment is the transferred garment
x-tilde (Eq. 15); phase 2 solves the inverse pattern design problem Sim(theta) = x-tilde
(Eq. 3) with Algorithm 1's own optimizer on the positional cost alone (plus R^fix and
R^cur), every other cost strength zero.

fixed-point (paper Section 8.1, after Bartle et al. 2016): drape the pattern on the
target body, move every triangle's pattern towards the shape that would drape onto
x-tilde (``pattern_update``), and repeat while the update keeps shrinking. It treats the
simulator as a black box: no gradient, no cost terms.

Both start where Algorithm 1 starts (``GradeSettings.start``: the level-scaled pattern by
default, the unchanged base pattern with start "base"), held to the same R^fix / R^cur
anchor; their results are scored with the same grading objective f as Algorithm 1's.
"""
from __future__ import annotations

import time

import numpy as np

from .costs import CostSet, Strengths
from .descent import descend
from .objective import Objective
from .output import SearchOutcome, mismatch_mm
from .pattern_update import FixedPointUpdate
from .presets import preset

# The fixed-point baseline's update: the whole of each update is taken, with R^fix + R^cur
# in it (docs/grading.md), until no boundary vertex moves more than this (mm).
FIXED_POINT_RELAXATION = 1.0
FIXED_POINT_TOLERANCE_MM = 0.1


def positional_strength(ctx) -> float:
    """delta_pos of the baselines, which both work on the positional cost: the preset's, or
    the paper's Table 1 value where the grading's preset leaves the term out (skirt)."""
    return ctx.strengths.pos if ctx.strengths.pos > 0 else preset("dress").strengths.pos


def start(ctx):
    """(theta, exact drape) the baselines start from: where Algorithm 1 starts its
    initialization (GradeSettings.start), so that every method is held to the same anchor."""
    theta = ctx.extra.get("theta_level")
    if theta is None:
        return ctx.param.theta_bar.copy(), ctx.start_from_base_pattern()
    return np.array(theta, dtype=float), ctx.exact(theta, ctx.xtilde, "level-scaled start")


def two_phase(ctx) -> SearchOutcome:
    """Phase 2 of the two-phase approach: Algorithm 1 on C^pos + R^fix + R^cur."""
    s = ctx.strengths
    phase2 = Strengths(fix=s.fix, cur=s.cur, pos=positional_strength(ctx))
    costs = CostSet(ctx.mesh, ctx.xbar, phase2, xtilde=ctx.xtilde)
    objective = Objective(ctx.param, ctx.regs, costs, ctx.sim, ctx.adjoint)
    theta0, first = start(ctx)
    out = descend(ctx, objective, theta0, first.x)
    f_start = out.checkpoints[0]["search_objective"]
    f_end = out.checkpoints[-1]["search_objective"]
    out.details["two_phase"] = {"strengths": {"fix": phase2.fix, "cur": phase2.cur, "pos": phase2.pos},
                                "phase2_objective_initial": f_start, "phase2_objective_final": f_end}
    return out


def fixed_point(ctx) -> SearchOutcome:
    """Bartle-style fixed-point iteration on the pattern, towards Sim(theta) = x-tilde."""
    settings, param = ctx.settings, ctx.param
    pos = positional_strength(ctx)
    update = FixedPointUpdate(ctx.mesh, param, pos, ctx.regs)
    t_loop = time.perf_counter()
    theta0, first = start(ctx)
    theta, x = theta0.copy(), first.x.copy()
    m = mismatch_mm(x, ctx.xtilde)
    f = ctx.objective.objective(x, theta)[0]
    hist = {"iteration": [0], "objective": [f], "mismatch_mm": [m], "update_mm": [],
            "seconds": [0.0]}
    best = (m, theta.copy(), x.copy(), 0)
    checkpoints = [{"iteration": 0, "objective": f, "search_objective": m}]
    relax = FIXED_POINT_RELAXATION
    previous_update = np.inf
    converged, message, k = False, "iteration limit", 0
    while k < settings.max_outer_iterations:
        p_new = update.target_pattern(param.pattern(theta), x, ctx.xtilde)
        theta_new = param.theta_of(p_new)
        if not np.all(np.isfinite(theta_new)):
            message = "the fixed-point update became non-finite; kept the best pattern so far"
            break
        u = 1000.0 * float(np.max(np.linalg.norm(theta_new - theta, axis=1)))
        if u <= FIXED_POINT_TOLERANCE_MM:
            converged = True
            message = f"the pattern update fell below {FIXED_POINT_TOLERANCE_MM:g} mm"
            break
        if u >= previous_update:
            message = (f"stagnated: the pattern update stopped shrinking ({previous_update:.3g} mm, then "
                       f"{u:.3g} mm) with the garment {best[0]:.3g} mm RMS from x-tilde; the inverse "
                       f"problem Sim(theta) = x-tilde may have no exact solution (paper Section 3)")
            break
        previous_update = u
        theta = theta + relax * (theta_new - theta)
        k += 1
        res = ctx.exact(theta, x, "fixed point")
        if not np.all(np.isfinite(res.x)):
            message = "the drape of the updated pattern became non-finite; kept the best pattern so far"
            break
        x = res.x
        m = mismatch_mm(x, ctx.xtilde)
        f = ctx.objective.objective(x, theta)[0]
        for key, v in (("iteration", k), ("objective", f), ("mismatch_mm", m), ("update_mm", u),
                       ("seconds", time.perf_counter() - t_loop)):
            hist[key].append(v)
        checkpoints.append({"iteration": k, "objective": f, "search_objective": m})
        ctx.tell(stage="optimize", iteration=k, objective=f, exact=True, mismatch_mm=m, update_mm=u)
        if m < best[0]:
            best = (m, theta.copy(), x.copy(), k)
        if settings.time_budget_s and time.perf_counter() - ctx.t_start > settings.time_budget_s:
            message = "time budget reached"
            break
    m_best, theta_best, x_best, k_best = best
    return SearchOutcome(
        theta=theta_best, x=x_best, theta_start=theta0.copy(), x_start=first.x.copy(),
        iterations=k, iterations_done=k, converged=converged, message=message, checkpoints=checkpoints,
        cost_evaluations=dict.fromkeys(ctx.objective.evaluations, 0), history=hist,
        seconds_loop=time.perf_counter() - t_loop,
        details={"fixed_point": {"mismatch_mm": hist["mismatch_mm"], "update_mm": hist["update_mm"],
                                 "best_iteration": k_best, "best_mismatch_mm": m_best,
                                 "relaxation": relax, "tolerance_mm": FIXED_POINT_TOLERANCE_MM}})
