"""The objective f(x, theta) = C(x, p(theta)) + R(theta) (paper Eq. 1, Sections 5-6)
and its adjoint gradient (Eq. 18-19). R holds R^fix and R^cur and, when its strength is
not 0, the seam-length term R^seam (seamfit.opt.seam)."""
from __future__ import annotations

import numpy as np

from ..device_arrays import is_device


class Objective:
    """Value and gradient of f at a garment state x and pattern parameters theta.

    ``costs`` decides which terms are in f: the grading objective holds the preset's
    strengths, the two-phase baseline a CostSet with the positional term only.
    ``seam`` (a ``SeamLength``) adds R^seam; it depends on theta alone, so its gradient
    joins R's after the adjoint step, and a zero strength skips it entirely."""

    def __init__(self, param, regs, costs, sim, adjoint, seam=None):
        self.param, self.regs, self.costs, self.sim, self.adjoint = param, regs, costs, sim, adjoint
        self.seam = seam

    def _seam(self, theta):
        if self.seam is None or not self.seam.active:
            return 0.0, None
        return self.seam.evaluate(theta)

    def objective(self, x, theta) -> tuple[float, dict]:
        p = self.param.pattern(theta)
        c, terms, _, _ = self.costs.evaluate(x, p)
        r, rterms, _ = self.regs.evaluate(theta)
        rs, _ = self._seam(theta)
        return float(c + r + rs), {**{k: float(v) for k, v in terms.items()},
                                   **{k: float(v) for k, v in rterms.items()}, "seam": float(rs)}

    def gradient(self, x, theta, residual: float | None = None) -> tuple[float, np.ndarray]:
        """f and its gradient in theta; `residual`: x's relative residual when its
        solve reported it (else the adjoint evaluates it where it needs it). With x and
        theta DeviceArrays every step runs on the GPU and the gradient is a DeviceArray
        (the parametrization's buffer, valid until its next call)."""
        p = self.param.pattern(theta)
        c, _, gx, gp = self.costs.evaluate(x, p)
        r, _, gr = self.regs.evaluate(theta)
        rs, gs = self._seam(theta)
        gp_total = self.adjoint.pattern_gradient(x, gx, gp, residual=residual)
        g = self.param.adjoint(gp_total)
        if is_device(g):
            g.axpy(1.0, gr)
            if gs is not None:
                g.axpy(1.0, gs)
            return float(c + r + rs), g
        g = g + gr
        if gs is not None:
            g = g + gs
        return float(c + r + rs), g

    @property
    def evaluations(self) -> dict:
        """Evaluations of every term of C, and of R^seam."""
        return {**self.costs.evaluations, "seam": self.seam.evaluations if self.seam is not None else 0}
