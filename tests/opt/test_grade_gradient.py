"""The full chain theta -> p -> x(p) -> F(x, p) + R(theta): the adjoint gradient
(paper Eq. 18-19) against central finite differences on converged equilibria."""
import numpy as np
import pytest

from opt_synthetic import two_panels
from seamfit.opt import CostSet, Parametrization, Regularizers, Strengths
from seamfit.opt.adjoint import AdjointSolver
from seamfit.opt.objective import Objective
from seamfit.sim.model import Fabric, SimSettings, Simulator


def hanging_problem(psd):
    """Two panels hanging from pins along their top edges: a well-posed equilibrium
    with springs in tension, no body."""
    mesh = two_panels(seed=3, jitter=0.2, scale=0.5)
    # stand the panels up (pattern v -> world z) so gravity pulls along v
    p = mesh.uv_cm / 100.0
    mesh.x0 = np.c_[p[:, 0], np.zeros(len(p)), 1.0 + p[:, 1]]
    sim = Simulator(mesh, None, Fabric(stretch_stiffness=50.0, bending_stiffness=1e-6), SimSettings())
    top = [i for i in range(len(p)) if mesh.boundary[i] and
           p[i, 1] >= p[mesh.vertex_panel == mesh.vertex_panel[i], 1].max() - 1e-9]
    sim.set_sticking(top, mesh.x0[top], stiffness=200.0)
    x = sim.solve(mesh.x0, tolerance=1e-11, method="newton", max_iterations=200).x
    strengths = Strengths(fix=100.0, cur=1e3, str=1.0, pos=100.0, smo=0.05)
    xtilde = x + np.array([0.01, 0.0, -0.02]) * (p[:, 1:2] / p[:, 1].max())
    param = Parametrization(mesh)
    regs = Regularizers(param, strengths.fix, strengths.cur)
    costs = CostSet(mesh, x, strengths, xtilde=xtilde)
    adj = AdjointSolver(sim, psd=psd)
    return mesh, sim, param, Objective(param, regs, costs, sim, adj), x


def total_objective(sim, param, prob, theta, x_start):
    sim.set_pattern(param.pattern(theta))
    res = sim.solve(x_start, tolerance=1e-11, method="newton", max_iterations=200)
    assert res.converged, res.message
    return prob.objective(res.x, theta)[0]


def gradient_errors(psd):
    mesh, sim, param, prob, x = hanging_problem(psd)
    theta = param.theta_bar.copy()
    sim.set_pattern(param.pattern(theta))
    _, g = prob.gradient(x, theta)
    rng = np.random.default_rng(7)
    errs = []
    for _ in range(3):
        d = rng.standard_normal(theta.shape) * 1e-3
        h = 1e-2
        fp = total_objective(sim, param, prob, theta + h * d, x)
        fm = total_objective(sim, param, prob, theta - h * d, x)
        fd = (fp - fm) / (2 * h)
        an = float(np.sum(g * d))
        errs.append(abs(fd - an) / max(abs(fd), 1e-12))
    return errs


def test_adjoint_gradient_matches_finite_differences():
    # the optimizer's solver (exact Hessian, tiny shift): exact up to FD truncation
    errs = gradient_errors(psd=False)
    assert max(errs) < 1e-3, errs


def test_projected_hessian_is_a_worse_adjoint():
    # why the PSD projection is not the default: with compressed springs it bends the gradient
    exact = gradient_errors(psd=False)
    projected = gradient_errors(psd=True)
    assert max(projected) > 10 * max(exact)
