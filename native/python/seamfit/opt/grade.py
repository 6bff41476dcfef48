"""Sewing pattern adjustment, the paper's Algorithm 1.

    xbar   <- Sim_phibar(thetabar)              base garment on the base body (cached)
    xtilde <- Transfer(xbar, phibar, phi)       Eq. 15
    theta0 <- Initialize(thetabar, xbar, xtilde)
    x0     <- Sim_phi(theta0)
    loop:  theta <- theta - s P^-1 Grad(x, theta)          Eq. 18-19 (adjoint)
           every M iterations an exact simulation; if the objective rose since the
           last exact checkpoint: go back there, double S, halve s ("long-range
           backtracking"); otherwise halve S (not below S_min) and grow s
           else x <- S simulation iterations from the previous x (inexact)

The result is always an exact checkpoint, so the reported objective is that of a
converged drape, and it never ends higher than the checkpoint before it.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from ..cache import content_key, load_arrays, save_arrays
from ..errors import SolveError
from ..mesh import build_sewn_mesh, outline_from_uv
from ..pattern import Pattern, check_pattern
from ..pattern.checks import output_checks
from ..pattern.refit import refit_pattern
from ..sim.model import Fabric, SimSettings, Simulator
from .adjoint import AdjointSolver
from .costs import CostSet, Strengths
from .fit import ease_report
from .initialize import initialize_pattern
from .parametrization import Parametrization
from .presets import preset
from .regularizers import Regularizers
from .transfer import DEFAULT_BANDWIDTH, transfer_garment


@dataclass
class GradeSettings:
    """Controls of one grading run. Strength coefficients come from ``preset`` unless
    ``strengths`` is given (Strengths or a dict with fix, cur, dis, smo, str, pos)."""
    preset: str = "dress"
    strengths: Optional[object] = None
    edge_length_cm: float = 1.5
    sdf_spacing: float = 0.0025        # the paper's 2.5 mm
    inner_iterations: int = 8          # S: simulation iterations per outer iteration
    min_inner_iterations: int = 2
    max_inner_iterations: int = 512
    checkpoint_every: int = 32         # M: exact simulation every M outer iterations
    max_outer_iterations: int = 256
    step: float = 1.0                  # s: step along -P^-1 grad
    max_move_mm: float = 1.0           # trust region at s = 1: no boundary vertex moves more per iteration
    step_growth: float = 1.5
    max_step: float = 16.0
    min_step: float = 1e-4
    rel_tol: float = 1e-3              # stop when a checkpoint lowers f by less than rel_tol * f
    exact_tolerance: Optional[float] = None   # residual of exact solves (default: SimSettings.tolerance)
    bandwidth: float = DEFAULT_BANDWIDTH      # B of Eq. 15 (m)
    evaluate_base_pattern: bool = True        # also drape the unchanged pattern on the target
    time_budget_s: float = 0.0                # 0: none

    def resolved_strengths(self) -> Strengths:
        if self.strengths is not None:
            return Strengths.from_any(self.strengths)
        return preset(self.preset).strengths

    def validate(self) -> None:
        if self.inner_iterations < 1 or self.checkpoint_every < 1 or self.max_outer_iterations < 0:
            raise SolveError("inner_iterations and checkpoint_every must be >= 1, max_outer_iterations >= 0")
        if not (self.step > 0 and self.edge_length_cm > 0 and self.sdf_spacing > 0):
            raise SolveError("step, edge_length_cm and sdf_spacing must be > 0")


@dataclass
class GradeResult:
    pattern: Pattern                   # the adjusted pattern (new object)
    uv_cm: np.ndarray                  # adjusted pattern coordinates of every mesh vertex
    x: np.ndarray                      # final drape on the target body (N, 3) m
    xbar: np.ndarray                   # base drape on the base body
    xtilde: np.ndarray                 # transferred garment
    mesh: object
    report: dict
    history: dict = field(default_factory=dict)


ProgressFn = Callable[[dict], Optional[bool]]


def base_drape(mesh, pattern, body, sdf, fabric: Fabric, settings: SimSettings, *, progress=None):
    """x-bar, the base garment on the base body, cached on disk by content."""
    from ..sim.dressing import initial_positions
    key = content_key("base-drape-1", mesh.cache_key(), body.vertices, body.faces, float(sdf.spacing),
                      asdict(fabric), asdict(settings))
    hit = load_arrays("drape", key)
    if hit is not None and hit["x"].shape == mesh.x0.shape:
        return hit["x"], {"cached": True, "key": key, **{k: float(hit[k]) for k in ("residual", "seconds")}}
    sim = Simulator(mesh, sdf, fabric, settings)
    x0, _ = initial_positions(mesh, pattern, sdf, mode="auto")
    res = sim.drape(x0, progress=progress)
    if res.cancelled:
        raise SolveError("cancelled while draping the base garment")
    if not res.converged:
        raise SolveError(f"the base garment did not settle on the base body: {res.message} "
                         f"(residual {res.residual:.3g}); raise max_iterations or check the placement")
    save_arrays("drape", key, {"x": res.x, "residual": np.float64(res.residual), "seconds": np.float64(res.seconds)})
    return res.x, {"cached": False, "key": key, "residual": res.residual, "seconds": res.seconds,
                   "iterations": res.iterations, "max_sewing_gap_mm": res.max_sewing_gap_mm,
                   "min_phi_mm": res.min_phi_mm}


def _remove_panel_rotations(mesh, uv_new_cm: np.ndarray) -> tuple[np.ndarray, dict]:
    """Rotate each panel back onto the base's grain. A rigid motion of a flat panel
    changes nothing in the sewn garment (rest lengths, flat bending rest state and
    masses are invariant), so this keeps the grain line without changing the fit."""
    out = uv_new_cm.copy()
    angles = {}
    for k, name in enumerate(mesh.panel_names):
        idx = np.flatnonzero(np.asarray(mesh.vertex_panel) == k)
        a = mesh.uv_cm[idx]
        b = uv_new_cm[idx]
        ca, cb = a.mean(axis=0), b.mean(axis=0)
        A, B = a - ca, b - cb
        # best rotation taking B onto A (2D Procrustes)
        num = np.sum(B[:, 0] * A[:, 1] - B[:, 1] * A[:, 0])
        den = np.sum(B[:, 0] * A[:, 0] + B[:, 1] * A[:, 1])
        ang = float(np.arctan2(num, den))
        c, s = np.cos(ang), np.sin(ang)
        R = np.array([[c, -s], [s, c]])
        out[idx] = B @ R.T + cb
        angles[name] = float(np.degrees(-ang))
    return out, angles


class _Problem:
    """Objective and gradient of the outer loop at (x, theta)."""

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


def grade(base_pattern: Pattern, base_body, target_body, settings: GradeSettings | None = None, *,
          fabric: Fabric | None = None, sim_settings: SimSettings | None = None,
          progress: ProgressFn | None = None) -> GradeResult:
    """Adjust ``base_pattern`` (fitting ``base_body``) to ``target_body``.

    progress(info) is called with a dict (stage, outer iteration, objective, ...);
    returning False cancels (SolveError "cancelled")."""
    from ..body import build_sdf

    settings = settings or GradeSettings()
    settings.validate()
    fabric = fabric or Fabric()
    sim_settings = sim_settings or SimSettings()
    strengths = settings.resolved_strengths()
    t_start = time.perf_counter()
    hist: dict[str, list] = {"iteration": [], "objective": [], "seconds": [], "exact": [], "S": [], "step": []}

    def tell(**info):
        if progress is not None and progress(info) is False:
            raise SolveError("cancelled")

    check_pattern(base_pattern)
    tell(stage="mesh")
    mesh = build_sewn_mesh(base_pattern, edge_length_cm=settings.edge_length_cm)
    tell(stage="sdf")
    base_sdf = build_sdf(base_body, spacing=settings.sdf_spacing)
    target_sdf = build_sdf(target_body, spacing=settings.sdf_spacing)

    def sim_progress(stage):
        def cb(it, res):
            return None if progress is None else progress({"stage": stage, "sim_iteration": it, "residual": res})
        return cb

    tell(stage="base drape")
    xbar, base_info = base_drape(mesh, base_pattern, base_body, base_sdf, fabric, sim_settings,
                                 progress=sim_progress("base drape"))
    tell(stage="transfer")
    xtilde = transfer_garment(xbar, base_body, target_body, settings.bandwidth)

    param = Parametrization(mesh)
    regs = Regularizers(param, strengths.fix, strengths.cur)
    costs = CostSet(mesh, xbar, strengths, target_sdf=target_sdf, base_sdf=base_sdf, xtilde=xtilde)
    sim = Simulator(mesh, target_sdf, fabric, sim_settings)
    adjoint = AdjointSolver(sim)
    prob = _Problem(param, regs, costs, sim, adjoint)
    exact_tol = settings.exact_tolerance or sim_settings.tolerance

    def exact(theta, x_start, stage):
        sim.set_pattern(param.pattern(theta))
        res = sim.solve(x_start, tolerance=exact_tol, progress=sim_progress(stage))
        if res.cancelled:
            raise SolveError("cancelled")
        return res

    objective_base = None
    terms_base = None
    if settings.evaluate_base_pattern:
        tell(stage="base pattern on target")
        rb = exact(param.theta_bar, xtilde, "base pattern on target")
        objective_base, terms_base = prob.objective(rb.x, param.theta_bar)

    tell(stage="initialize")
    init = initialize_pattern(mesh, xbar, xtilde, strengths, param=param, regularizers=regs)
    theta = init.theta.copy()
    tell(stage="initial drape")
    r0 = exact(theta, xtilde, "initial drape")
    x = r0.x
    f0, terms0 = prob.objective(x, theta)
    t_loop = time.perf_counter()
    seconds_precompute = t_loop - t_start

    ck_theta, ck_x, ck_f = theta.copy(), x.copy(), f0
    checkpoints = [(0, f0)]   # accepted exact checkpoints (iteration, objective)
    S, s = settings.inner_iterations, settings.step
    k = 0              # accepted outer iterations
    work = 0           # outer iterations done, discarded ones included
    backtracks, converged, message = 0, False, "iteration limit"
    hist_append = lambda f, exact_flag: (hist["iteration"].append(work), hist["objective"].append(f),  # noqa: E731
                                         hist["seconds"].append(time.perf_counter() - t_loop),
                                         hist["exact"].append(exact_flag), hist["S"].append(S),
                                         hist["step"].append(s))
    hist_append(f0, True)
    max_work = 4 * settings.max_outer_iterations
    while k < settings.max_outer_iterations and work < max_work:
        f_cur, g = prob.gradient(x, theta)
        d = -regs.apply_preconditioner(g)
        # The preconditioner fixes the direction's shape, not its scale: cap the move
        # so an inexact state far from equilibrium cannot throw the pattern away.
        # The trust radius shrinks and grows with s, so backtracking really shortens steps.
        dmax = float(np.max(np.abs(d))) if d.size else 0.0
        step = s if dmax == 0 else s * min(1.0, 1e-3 * settings.max_move_mm / dmax)
        theta = theta + step * d
        k += 1
        work += 1
        sim.set_pattern(param.pattern(theta))
        at_checkpoint = (k % settings.checkpoint_every == 0) or k == settings.max_outer_iterations
        if not at_checkpoint:
            res = sim.solve(x, tolerance=1e-12, max_iterations=S)
            x = res.x
            hist_append(f_cur, False)
            tell(stage="optimize", iteration=k, objective=f_cur, exact=False)
            if settings.time_budget_s and time.perf_counter() - t_start > settings.time_budget_s:
                at_checkpoint = True
            else:
                continue
        res = exact(theta, x, "checkpoint")
        f, f_terms = prob.objective(res.x, theta)
        sim_state = {"converged": res.converged, "residual": res.residual,
                     "max_sewing_gap_mm": res.max_sewing_gap_mm, "min_phi_mm": res.min_phi_mm, "terms": f_terms}
        if not (np.isfinite(f) and f <= ck_f):
            # Long-range backtracking: back to the last exact state, simulate more
            # accurately and take shorter steps.
            backtracks += 1
            k = (k - 1) // settings.checkpoint_every * settings.checkpoint_every
            theta, x = ck_theta.copy(), ck_x.copy()
            sim.set_pattern(param.pattern(theta))
            S = min(2 * S, settings.max_inner_iterations)
            s *= 0.5
            hist_append(f, True)
            tell(stage="optimize", iteration=k, objective=f, exact=True, backtrack=True, state=sim_state)
            if s < settings.min_step:
                converged, message = True, "no further decrease at the smallest step"
                break
            continue
        decrease = ck_f - f
        ck_theta, ck_x, ck_f = theta.copy(), res.x.copy(), f
        checkpoints.append((k, f))
        x = res.x
        hist_append(f, True)
        tell(stage="optimize", iteration=k, objective=f, exact=True, state=sim_state)
        S = max(S // 2, settings.min_inner_iterations)
        s = min(s * settings.step_growth, settings.max_step)
        if decrease <= settings.rel_tol * abs(f):
            converged, message = True, "objective no longer falls"
            break
        if settings.time_budget_s and time.perf_counter() - t_start > settings.time_budget_s:
            message = "time budget reached"
            break

    theta, x, f_final = ck_theta, ck_x, ck_f
    f_final, terms_final = prob.objective(x, theta)
    seconds_loop = time.perf_counter() - t_loop

    uv_raw = 100.0 * param.pattern(theta)
    uv_new, rotations = _remove_panel_rotations(mesh, uv_raw)
    outlines = outline_from_uv(mesh, uv_new)
    refit = refit_pattern(base_pattern, outlines)
    checks = output_checks(base_pattern, refit.pattern)

    ease_base = ease_report(base_body, xbar, mesh.triangles)
    ease_result = ease_report(target_body, x, mesh.triangles)
    gaps = sim.sewing_gaps(x)
    phi = sim.phi(x)
    report = {
        "objective_base_pattern": objective_base,
        "objective_initial": f0,
        "objective_final": f_final,
        "objective_reduction": (f0 - f_final) / f0 if f0 > 0 else 0.0,
        "terms_base_pattern": terms_base,
        "terms_initial": terms0,
        "terms_final": terms_final,
        "strengths": asdict(strengths),
        "outer_iterations": k,
        "checkpoints": [{"iteration": i, "objective": float(v)} for i, v in checkpoints],
        "cost_evaluations": dict(costs.evaluations),
        "outer_iterations_done": work,
        "backtracks": backtracks,
        "converged": converged,
        "message": message,
        "seconds_total": time.perf_counter() - t_start,
        "seconds_precompute": seconds_precompute,
        "seconds_loop": seconds_loop,
        "seconds_per_iteration": seconds_loop / max(work, 1),
        "max_displacement_mm": checks.get("max_displacement_mm"),
        "seam_mismatch_mm": {str(s_["index"]): s_["seam_mismatch_mm"] for s_ in checks.get("stitches", [])},
        "checks": checks,
        "refit": {"ok": refit.ok, "max_deviation_mm": refit.max_deviation_overall_mm,
                  "failed": [list(map(str, f_)) for f_ in refit.failed], "notes": refit.notes},
        "panel_rotation_removed_deg": rotations,
        "ease_cm": {"base": ease_base, "result": ease_result},
        "drape": {"max_sewing_gap_mm": float(gaps.max() * 1000) if len(gaps) else 0.0,
                  "min_phi_mm": float(phi.min() * 1000)},
        "base_drape": base_info,
        "initialization": {"objective_history": [float(v) for v in init.history.get("objective", [])][-1:],
                           "message": init.message},
        "mesh": {"vertices": int(len(mesh.uv_cm)), "triangles": int(len(mesh.triangles)),
                 "edge_length_cm": settings.edge_length_cm},
        "settings": {k_: v for k_, v in asdict(replace(settings, strengths=None)).items()},
    }
    return GradeResult(pattern=refit.pattern, uv_cm=uv_new, x=x, xbar=xbar, xtilde=xtilde, mesh=mesh,
                       report=report, history=hist)
