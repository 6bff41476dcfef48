"""Sewing pattern adjustment: the paper's Algorithm 1 and, for comparison, two baselines.

    xbar   <- Sim_phibar(thetabar)              base garment on the base body (cached)
    xtilde <- Transfer(xbar, phibar, phi)       Eq. 15
    theta0 <- Initialize(thetabar, xbar, xtilde)
    x0     <- Sim_phi(theta0)
    loop (seamfit.opt.descent)

``GradeSettings.method`` picks the search between the shared preparation
(``seamfit.opt.prepare``) and the shared output (``seamfit.opt.output``):
"adjoint" (Algorithm 1, the default), "two-phase" (Section 3, positional cost only) or
"fixed-point" (Section 8.1, after Bartle et al. 2016); see ``seamfit.opt.baselines``.
Every method's result is scored with the same objective f (the preset's strengths).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..cache import wait_for_writes
from ..errors import PatternError, SolveError
from ..mesh.boundary import DEFAULT_EDGE_LENGTH_CM
from ..pattern import Pattern
from ..sim.model import Fabric, SimSettings
from ..sim.multilevel import prolong
from .baselines import fixed_point, two_phase
from .coarse_start import coarse_edge_for, fine_settings, grade_coarse
from .costs import Strengths
from .descent import descend
from ..device_arrays import host
from .initialize import initialize_pattern
from .output import GradeResult, SearchOutcome, finish
from .prepare import ProgressFn, base_drape, prepare
from .presets import preset
from .sdf_region import GARMENT_REGION_MARGIN, check_sdf_region, garment_outside_field
from .transfer import DEFAULT_BANDWIDTH

METHODS = ("adjoint", "two-phase", "fixed-point")
STARTS = ("base", "level")

__all__ = ["METHODS", "GradeResult", "GradeSettings", "ProgressFn", "base_drape", "grade"]


@dataclass
class GradeSettings:
    """Controls of one grading run. Strength coefficients come from ``preset`` unless
    ``strengths`` is given (Strengths or a dict with fix, cur, dis, smo, str, pos, seam)."""
    preset: str = "auto"               # auto: by the pattern's garment_type (presets.preset_for_garment)
    strengths: Optional[object] = None
    method: str = "adjoint"            # adjoint | two-phase | fixed-point
    # theta^(0) and the anchor of R^fix / R^cur: "level" (the base pattern stretched level
    # by level by the bodies' girths and heights, seamfit.opt.level_scale; median landmark
    # error 1.81 cm against 2.50 on the 57 shared cases, docs/accuracy_results.md) or
    # "base" (the paper: Section 7's initialization from the base pattern).
    start: str = "level"
    edge_length_cm: float = DEFAULT_EDGE_LENGTH_CM
    # Coarse-to-fine (seamfit.opt.coarse_start), adjoint method only: a mesh at least twice as
    # fine as coarse_edge_length_cm (0: every mesh graded directly) is graded at that edge
    # first and its pattern carried over; the finer mesh then takes fine_outer_iterations.
    coarse_edge_length_cm: float = DEFAULT_EDGE_LENGTH_CM
    fine_outer_iterations: int = 0
    sdf_spacing: float = 0.0025        # the paper's 2.5 mm
    # Where the body fields are built: "body" (whole body), "garment" (cut to the garment's
    # height band +- sdf_region_margin m) or "auto" (whole body unless its grid would exceed
    # the SDF builder's node limit; docs/grading.md, "The body fields' region").
    sdf_region: str = "auto"
    sdf_region_margin: float = GARMENT_REGION_MARGIN
    inner_iterations: int = 8          # S: simulation iterations per outer iteration
    min_inner_iterations: int = 2
    max_inner_iterations: int = 512
    checkpoint_every: int = 32         # M: exact simulation every M outer iterations
    # The knee of run time against error on the shared cases (docs/accuracy_time.md): past
    # 128 the search converges more cases and ends farther from the drafts.
    max_outer_iterations: int = 128
    fix_in_objective: bool = True      # R^fix in f (the paper) or only in the preconditioner P (docs/grading.md)
    seam_in_preconditioner: bool = True   # add R^seam's Gauss-Newton Hessian at the base to P (docs/optimizer.md)
    step: float = 1.0                  # s: step along -P^-1 grad
    max_move_mm: float = 1.0           # trust region at s = 1: no boundary vertex moves more per iteration
    step_growth: float = 1.5
    max_step: float = 16.0
    min_step: float = 1e-4
    rel_tol: float = 1e-3              # stop when a checkpoint lowers f by less than rel_tol * f
    # stop when an accepted checkpoint moved no pattern point more than this (mm) since the
    # one before: the pattern has stopped moving, whatever f still does (0: never)
    stop_move_mm: float = 0.1
    exact_tolerance: Optional[float] = None   # residual of exact solves (default: SimSettings.tolerance)
    bandwidth: float = DEFAULT_BANDWIDTH      # B of Eq. 15 (m)
    # Also drape the unchanged pattern on the target, for the report's objective_base_pattern
    # only (the baselines drape it anyway): one more drape, 1.4 s of a 60K-triangle grading on
    # an H100, that changes no result.
    evaluate_base_pattern: bool = False
    time_budget_s: float = 0.0                # 0: none
    fixed_point_relaxation: float = 1.0       # fixed-point: fraction of each pattern update taken
    fixed_point_tolerance_mm: float = 0.1     # fixed-point: converged when no boundary vertex moves more
    fixed_point_regularize: bool = True       # fixed-point: R^fix + R^cur in the pattern update
    device: str = "auto"                      # simulations on auto | cpu | cuda (seamfit.device)
    # GPU adjoint at inexact states: MINRES tolerance max(1e-8, adjoint_forcing * residual),
    # no tighter than the state itself is resolved (inexact Newton's forcing rule). At settled
    # states it is 1e-8 always. 0: 1e-8 everywhere, as the CPU's direct solve; 0.01 (default)
    # grades the 60K skirt 4x faster to a lower objective (docs/gpu.md).
    adjoint_forcing: float = 0.01
    # On the GPU, keep theta and x in GPU memory between exact checkpoints (False: the
    # loop on host arrays, each GPU piece copying in and out; for measuring what it saves).
    device_state: bool = True
    # Timing benchmarks only: grade from a base drape that did not settle (the report's
    # base_drape says converged False) instead of stopping with SolveError.
    accept_unsettled_base: bool = False

    def resolved_strengths(self, garment_type: str | None = None) -> Strengths:
        if self.strengths is not None:
            return Strengths.from_any(self.strengths)
        return preset(self.preset, garment_type).strengths

    @property
    def drapes_base_pattern(self) -> bool:
        """Whether a grading drapes the unchanged pattern on the target: for the report
        (evaluate_base_pattern), or because its method starts from that drape (the baselines)."""
        return self.evaluate_base_pattern or self.method != "adjoint"

    def validate(self) -> None:
        if self.device not in ("auto", "cpu", "cuda"):
            raise SolveError(f"unknown device {self.device!r}; choose auto, cpu or cuda")
        if not (0 <= self.adjoint_forcing < 1):
            raise SolveError(f"adjoint_forcing must lie in [0, 1), got {self.adjoint_forcing}")
        if self.start not in STARTS:
            raise SolveError(f"unknown start {self.start!r}; choose one of {', '.join(STARTS)}")
        if self.method not in METHODS:
            raise SolveError(f"unknown grading method {self.method!r}; choose one of {', '.join(METHODS)}")
        if not (self.stop_move_mm >= 0):
            raise SolveError(f"stop_move_mm must be >= 0, got {self.stop_move_mm}")
        if not (self.coarse_edge_length_cm >= 0 and self.fine_outer_iterations >= 0):
            raise SolveError("coarse_edge_length_cm and fine_outer_iterations must be >= 0 (0: off / none)")
        if self.inner_iterations < 1 or self.checkpoint_every < 1 or self.max_outer_iterations < 0:
            raise SolveError("inner_iterations and checkpoint_every must be >= 1, max_outer_iterations >= 0")
        if not (self.step > 0 and self.edge_length_cm > 0 and self.sdf_spacing > 0):
            raise SolveError("step, edge_length_cm and sdf_spacing must be > 0")
        check_sdf_region(self.sdf_region)
        if not (self.sdf_region_margin >= 0):
            raise SolveError(f"sdf_region_margin must be >= 0 metres, got {self.sdf_region_margin}")
        if not (0 < self.fixed_point_relaxation <= 1 and self.fixed_point_tolerance_mm > 0):
            raise SolveError("fixed_point_relaxation must be in (0, 1] and fixed_point_tolerance_mm > 0")


def algorithm1(ctx) -> SearchOutcome:
    """The paper's method: initialization (Section 7), then adjoint descent on f."""
    coarse = ctx.extra.get("coarse_start")
    if coarse is not None:
        return _from_coarse(ctx, coarse)
    ctx.tell(stage="initialize")
    init = initialize_pattern(ctx.mesh, ctx.xbar, ctx.xtilde, ctx.strengths, param=ctx.param,
                              regularizers=ctx.regs, seam=ctx.seam, theta0=ctx.extra.get("theta_level"))
    theta0 = init.theta
    warm = ctx.extra.get("warm_start")
    if warm is not None:
        # A neighbouring size's search moved its pattern from its own initialization by
        # roughly what this size needs too: start from this initialization plus that move.
        theta0 = init.theta + (np.asarray(warm["theta"], float) - np.asarray(warm["theta_init"], float))
    ctx.tell(stage="initial drape")
    r0 = ctx.exact(theta0, ctx.xtilde, "initial drape")
    out = descend(ctx, ctx.objective, theta0, r0.x)
    out.initialization = {"objective_history": [float(v) for v in init.history.get("objective", [])][-1:],
                          "message": init.message, "warm_start": warm is not None}
    ctx.extra["theta_init"] = np.array(init.theta, dtype=float)
    return out


def _from_coarse(ctx, coarse) -> SearchOutcome:
    """The search on the fine mesh from the coarse level's result (seamfit.opt.coarse_start):
    Section 7's initialization and the long search were the coarse level's."""
    theta0 = np.array(ctx.extra["theta_level"], dtype=float)   # prepare carried it from the coarse level
    ctx.tell(stage="initial drape")
    r0 = ctx.exact(theta0, prolong(coarse.mesh, coarse.x, ctx.mesh), "initial drape")
    out = descend(ctx, ctx.objective, theta0, r0.x)
    out.initialization = {"objective_history": [], "message": "the coarse level's result, carried to this mesh",
                          "warm_start": False}
    if ctx.settings.max_outer_iterations == 0:
        # No search here: the grading ended where the coarse level's search did.
        edge = coarse.report["edge_length_cm"]
        out.converged = bool(coarse.report["converged"])
        out.message = f"coarse level ({edge:g} cm): {coarse.report['message']}; carried to this mesh"
    ctx.extra["theta_init"] = np.array(theta0, dtype=float)
    return out


SEARCHES = {"adjoint": algorithm1, "two-phase": two_phase, "fixed-point": fixed_point}


def grade(base_pattern: Pattern, base_body, target_body, settings: GradeSettings | None = None, *,
          fabric: Fabric | None = None, sim_settings: SimSettings | None = None,
          progress: ProgressFn | None = None, warm_start: dict | None = None,
          shared: dict | None = None) -> GradeResult:
    """Adjust ``base_pattern`` (fitting ``base_body``) to ``target_body`` with
    ``settings.method``.

    progress(info) is called with a dict (stage, outer iteration, objective, ...);
    returning False cancels (SolveError "cancelled"). For a size run (seamfit.opt.size_run):
    ``warm_start`` is a neighbouring size's ``GradeResult.warm_start`` (adjoint method only)
    and ``shared`` a dict kept across the run's calls, holding what depends only on the base
    (mesh, base field and drape, base ease)."""
    settings = settings or GradeSettings()
    settings.validate()
    t0 = time.perf_counter()
    coarse, max_outer_iterations, skipped = None, settings.max_outer_iterations, None
    if coarse_edge_for(settings):
        # Coarse-to-fine: the search on the coarse mesh; on this one fine_outer_iterations (default none).
        try:
            coarse = grade_coarse(base_pattern, base_body, target_body, settings, fabric=fabric,
                                  sim_settings=sim_settings, progress=progress,
                                  warm_start=(warm_start or {}).get("coarse"),
                                  shared=None if shared is None else shared.setdefault("coarse", {}))
        except PatternError as exc:
            # A panel too narrow for the coarse edge: this mesh is graded directly.
            skipped = {"skipped": f"the {coarse_edge_for(settings):g} cm coarse level could not be meshed "
                                  f"({exc}); graded on this mesh directly"}
        else:
            settings = fine_settings(settings)
    ctx = prepare(base_pattern, base_body, target_body, settings, fabric=fabric, sim_settings=sim_settings,
                  progress=progress, shared=shared, coarse=coarse)
    if coarse is not None:
        ctx.t_start = t0          # the report's seconds hold the coarse level's too
        ctx.extra["coarse_start"] = coarse
    elif warm_start is not None and settings.method == "adjoint":
        ctx.extra["warm_start"] = warm_start
    outcome = SEARCHES[settings.method](ctx)
    ctx.tell(stage="refit")    # the pattern's curves refitted, the checks and the report
    result = finish(ctx, settings.method, outcome)
    # The fields' regions and sizes; a cropped target field is checked against the result
    # (the base one was checked at the end of the base drape).
    fields = ctx.extra["sdf"]
    warning = garment_outside_field(ctx.target_sdf, fields["target"], result.x, "target", "of the result")
    result.report["sdf"] = {**fields, **({"warning": warning} if warning else {})}
    if skipped is not None:
        result.report["coarse_level"] = skipped
    if coarse is not None:
        result.report["coarse_level"] = coarse.report
        # the settings as asked (the fine mesh's search took fine_outer_iterations of them)
        result.report["settings"]["max_outer_iterations"] = max_outer_iterations
        # a neighbouring size starts its coarse level from this one's
        result.warm_start = {"coarse": coarse.warm_start}
    elif "theta_init" in ctx.extra:
        result.warm_start = {"theta_init": ctx.extra["theta_init"], "theta": np.array(host(outcome.theta), dtype=float)}
    # The body fields went to the disk cache while the grading ran: on disk when it returns.
    wait_for_writes()
    return result
