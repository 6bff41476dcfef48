"""Pattern initialization (paper Section 7, "Initialization").

With the garment held at the transferred shape x = xtilde, minimize

    f(theta) = C^str(xtilde, p(theta)) + R^fix(theta) + R^cur(theta) [+ R^seam(theta)]

by preconditioned gradient descent (P = Hessian of the regularizers) with a
backtracking (Armijo) line search. No simulation is involved, so this takes seconds.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .costs import CostSet, Strengths
from .parametrization import Parametrization
from .regularizers import Regularizers

ARMIJO_C = 1e-4
BACKTRACK = 0.5
MAX_BACKTRACKS = 40


@dataclass
class InitResult:
    theta: np.ndarray                  # (n_theta, 2) initial parameters theta0
    pattern: np.ndarray                # p(theta0), (N, 2) m
    history: dict = field(default_factory=dict)  # per accepted iterate: objective, str, fix, cur, step, seconds
    converged: bool = False
    message: str = ""


class _Objective:
    def __init__(self, param, regs, costs, xtilde, seam=None):
        self.param, self.regs, self.costs, self.x = param, regs, costs, xtilde
        self.seam = seam if seam is not None and seam.active else None

    def __call__(self, theta):
        p = self.param.pattern(theta)
        c, terms, _, gp = self.costs.evaluate(self.x, p)
        r, rterms, gr = self.regs.evaluate(theta)
        g = self.param.adjoint(gp) + gr
        if self.seam is not None:
            rs, gs = self.seam.evaluate(theta)
            r, g = r + rs, g + gs
        return c + r, {"str": terms["str"], "fix": rterms["fix"], "cur": rterms["cur"]}, g


def initialize_pattern(mesh, xbar, xtilde, strengths, *, param: Parametrization | None = None,
                       regularizers: Regularizers | None = None, seam=None, theta0=None, max_iters: int = 500,
                       time_budget_s: float = 5.0, rtol: float = 1e-10) -> InitResult:
    """theta0 for the outer loop. ``strengths`` supplies str, fix and cur (other terms are
    constant while x is fixed and are ignored); ``seam`` (a SeamLength) adds R^seam so
    theta0 already has matched stitch sides. Stops after ``max_iters`` iterations,
    ``time_budget_s`` seconds, or when an iteration lowers f by less than ``rtol * f``
    or no step along the preconditioned direction lowers f."""
    s = Strengths.from_any(strengths)
    param = param or Parametrization(mesh)
    regs = regularizers or Regularizers(param, s.fix, s.cur)
    costs = CostSet(mesh, xbar, Strengths(str=s.str))
    obj = _Objective(param, regs, costs, np.ascontiguousarray(xtilde, dtype=float), seam)

    t0 = time.perf_counter()
    theta = param.theta_bar.copy() if theta0 is None else np.array(theta0, dtype=float).reshape(-1, 2)
    f, terms, g = obj(theta)
    hist = {"objective": [f], "str": [terms["str"]], "fix": [terms["fix"]], "cur": [terms["cur"]],
            "step": [0.0], "seconds": [0.0]}
    step = 1.0
    converged, message = False, "iteration limit"
    for _ in range(max_iters):
        d = -regs.apply_preconditioner(g)
        slope = float(np.sum(g * d))
        if not slope < 0:
            converged, message = True, "no descent direction (gradient is zero)"
            break
        accepted = False
        for _bt in range(MAX_BACKTRACKS):
            trial = theta + step * d
            ft, tt, gt = obj(trial)
            if np.isfinite(ft) and ft <= f + ARMIJO_C * step * slope:
                accepted = True
                break
            step *= BACKTRACK
        if not accepted:
            converged, message = True, "line search found no decrease"
            break
        decrease = f - ft
        theta, f, terms, g = trial, ft, tt, gt
        hist["objective"].append(f)
        for k in ("str", "fix", "cur"):
            hist[k].append(terms[k])
        hist["step"].append(step)
        hist["seconds"].append(time.perf_counter() - t0)
        if decrease <= rtol * abs(f):
            converged, message = True, "relative decrease below tolerance"
            break
        if time.perf_counter() - t0 > time_budget_s:
            message = "time budget reached"
            break
        step = min(2.0 * step, 1e8)  # let the step grow again after a success
    return InitResult(theta=theta, pattern=param.pattern(theta), history=hist, converged=converged,
                      message=message)
