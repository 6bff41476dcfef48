"""The seam-length regularizer R^seam: zero on the base pattern, gradient against central
finite differences, its Gauss-Newton block, gathered stitches and the zero-strength skip."""

import numpy as np
import pytest

from seamfit.mesh import build_sewn_mesh
from seamfit.opt import SeamLength, Strengths, seam_segments
from seamfit.opt.objective import Objective
from seamfit.pattern import load_pattern
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"


@pytest.fixture(scope="module")
def mesh():
    return build_sewn_mesh(load_pattern(PATTERN), edge_length_cm=4.0)


def reference(theta, seg, rho, delta):
    la = np.linalg.norm(theta[seg[:, 1]] - theta[seg[:, 0]], axis=1)
    lb = np.linalg.norm(theta[seg[:, 3]] - theta[seg[:, 2]], axis=1)
    return 0.5 * delta * np.sum((la - rho * lb) ** 2)


def moved(param, rng, mm=5.0):
    return param.theta_bar + 1e-3 * mm * rng.normal(size=param.theta_bar.shape)


def test_segments_follow_the_stitches(mesh, param):
    seg = seam_segments(mesh, param)
    assert len(seg) == sum(len(p) - 1 for p in mesh.stitch_pairs)
    assert np.all(seg >= 0) and np.all(seg < param.n_theta)


def test_zero_on_the_base_pattern(mesh, param):
    s = SeamLength(param, mesh, 1e6)
    v, g = s.evaluate(param.theta_bar)
    assert v < 1e-20 and np.abs(g).max() < 1e-9
    assert np.abs(s.residuals(param.theta_bar)).max() < 1e-15


def test_ratios_are_one_except_gathered(mesh, param):
    s = SeamLength(param, mesh, 1.0)
    seg, rho = s.segments, s.ratios
    gathered = np.zeros(len(seg), bool)
    start = 0
    for st, pairs in zip(mesh.stitches, mesh.stitch_pairs):
        n = max(len(pairs) - 1, 0)
        gathered[start:start + n] = st.gathered
        start += n
    assert gathered.any(), "the sample skirt has gathered stitches"
    assert np.allclose(rho[~gathered], 1.0, atol=1e-3)   # meshing round-off only
    # the gathered side seams ease side b in: a / b = 20.67 / 21.70
    assert np.allclose(rho[gathered].mean(), 20.6681 / 21.7015, rtol=0.02)


def test_value_and_gradient(mesh, param):
    rng = np.random.default_rng(0)
    delta = 3e5
    s = SeamLength(param, mesh, delta)
    th = moved(param, rng)
    v, g = s.evaluate(th)
    assert v == pytest.approx(reference(th, s.segments, s.ratios, delta), rel=1e-12)
    worst = 0.0
    eps = 1e-7
    for _ in range(6):
        d = rng.normal(size=th.shape)
        d /= np.linalg.norm(d)
        fd = (s.evaluate(th + eps * d)[0] - s.evaluate(th - eps * d)[0]) / (2 * eps)
        an = float(np.sum(g * d))
        worst = max(worst, abs(fd - an) / max(abs(an), 1e-12))
    assert worst < 1e-6, worst


def test_gauss_newton_block(mesh, param):
    """At the base (r = 0) the Gauss-Newton matrix is the exact Hessian: J^T J, checked
    against finite differences of the gradient."""
    s = SeamLength(param, mesh, 2.0)
    H = s.gauss_newton()
    assert abs(H - H.T).max() < 1e-12
    rng = np.random.default_rng(1)
    eps = 1e-6
    for _ in range(3):
        d = rng.normal(size=param.theta_bar.shape)
        fd = (s.evaluate(param.theta_bar + eps * d)[1] - s.evaluate(param.theta_bar - eps * d)[1]) / (2 * eps)
        np.testing.assert_allclose(H @ d.reshape(-1), fd.reshape(-1), atol=1e-6 * np.abs(fd).max())


def test_zero_strength_is_never_evaluated(mesh, param):
    class Stub:
        evaluations = {"dis": 0, "smo": 0, "str": 0, "pos": 0}

        def evaluate(self, x, p):
            return 0.0, {}, np.zeros((len(p), 3)), np.zeros_like(p)

    class NoRegs:
        def evaluate(self, theta):
            return 0.0, {}, np.zeros_like(theta)

    s = SeamLength(param, mesh, Strengths().seam)
    obj = Objective(param, NoRegs(), Stub(), None, None, s)
    f, terms = obj.objective(None, moved(param, np.random.default_rng(2)))
    assert f == 0 and terms["seam"] == 0
    assert obj.evaluations["seam"] == 0 and s.evaluations == 0
    s.set_strength(1e5)
    f, terms = obj.objective(None, moved(param, np.random.default_rng(2)))
    assert f > 0 and terms["seam"] == f and obj.evaluations["seam"] == 1


def test_preconditioner_can_hold_the_seam_block(mesh, param):
    from seamfit.opt import Regularizers
    regs = Regularizers(param, 100.0, 1e6)
    s = SeamLength(param, mesh, 1e6)
    P0 = regs.hessian()
    regs.add_to_preconditioner(s.gauss_newton())
    assert abs(regs.hessian() - P0 - s.gauss_newton()).max() < 1e-6
    g = np.random.default_rng(3).normal(size=param.theta_bar.shape)
    out = regs.apply_preconditioner(g)
    np.testing.assert_allclose(regs.hessian() @ out.reshape(-1), g.reshape(-1), rtol=1e-6, atol=1e-9)
    regs.add_to_preconditioner(None)
    assert abs(regs.hessian() - P0).max() == 0
    regs.add_to_preconditioner(s.gauss_newton())
    assert abs(regs.hessian(extra=False) - P0).max() < 1e-6
