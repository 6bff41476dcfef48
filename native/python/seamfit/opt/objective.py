"""The objective f(x, theta) = C(x, p(theta)) + R(theta) (paper Eq. 1, Sections 5-6)
and its adjoint gradient (Eq. 18-19)."""
from __future__ import annotations

import numpy as np


class Objective:
    """Value and gradient of f at a garment state x and pattern parameters theta.

    ``costs`` decides which terms are in f: the grading objective holds the preset's
    strengths, the two-phase baseline a CostSet with the positional term only."""

    def __init__(self, param, regs, costs, sim, adjoint):
        self.param, self.regs, self.costs, self.sim, self.adjoint = param, regs, costs, sim, adjoint

    def objective(self, x, theta) -> tuple[float, dict]:
        p = self.param.pattern(theta)
        c, terms, _, _ = self.costs.evaluate(x, p)
        r, rterms, _ = self.regs.evaluate(theta)
        return float(c + r), {**{k: float(v) for k, v in terms.items()},
                              **{k: float(v) for k, v in rterms.items()}}

    def gradient(self, x, theta) -> tuple[float, np.ndarray]:
        p = self.param.pattern(theta)
        c, _, gx, gp = self.costs.evaluate(x, p)
        r, _, gr = self.regs.evaluate(theta)
        gp_total = self.adjoint.pattern_gradient(x, gx, gp)
        return float(c + r), self.param.adjoint(gp_total) + gr
