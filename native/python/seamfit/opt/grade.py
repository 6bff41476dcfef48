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
from ..settings import DRAPE, GRADE, Addon, check_fields, setting
from ..sim.multilevel import prolong
from .baselines import fixed_point, two_phase
from .coarse_start import coarse_edge_for, fine_settings, grade_coarse
from .costs import Strengths
from .descent import descend
from ..device_arrays import host
from .initialize import initialize_pattern
from .output import GradeResult, SearchOutcome, finish
from .prepare import ProgressFn, base_drape, prepare
from .presets import PRESETS, preset
from .sdf_region import GARMENT_REGION_MARGIN, SDF_REGIONS, garment_outside_field
from .transfer import DEFAULT_BANDWIDTH

METHODS = ("adjoint", "two-phase", "fixed-point")
STARTS = ("base", "level")

__all__ = ["METHODS", "GradeResult", "GradeSettings", "ProgressFn", "base_drape", "grade"]


@dataclass
class GradeSettings:
    """Controls of one grading run. Strength coefficients come from ``preset`` unless
    ``strengths`` is given (Strengths or a dict with fix, cur, dis, smo, str, pos, seam).
    The user's settings are declared with ``setting`` (seamfit.settings: their help, unit,
    range and front ends, docs/settings.md); the other fields are the solver's own."""
    preset: str = setting(
        "auto", "strength preset: auto picks one by the pattern's garment type (see below)",
        choices=("auto", *sorted(PRESETS)), flag="--preset", commands=GRADE)
    strengths: Optional[object] = None
    method: str = setting(
        "adjoint", "search: adjoint (the paper's Algorithm 1); two-phase and fixed-point are baselines for "
        "comparison, see below", choices=METHODS, flag="--method", commands=GRADE)
    # theta^(0) and the anchor of R^fix / R^cur (docs/method.md, "Level scaling")
    start: str = setting(
        "level", "where the search starts and what R^fix / R^cur hold it to: level (the base pattern stretched "
        "level by level by how much the body grew there) or base (the paper's start from the base pattern)",
        choices=STARTS, flag="--start", commands=GRADE)
    edge_length_cm: float = setting(
        DEFAULT_EDGE_LENGTH_CM, "mesh edge length: smaller is finer and slower", unit="cm", low=0, low_open=True,
        flag="--edge-length", metavar="CM", commands=GRADE + DRAPE + ("mesh",),
        addon=Addon("edge_length_cm", "Mesh resolution (cm)", minimum=0.3, maximum=20.0, precision=2))
    # Coarse-to-fine (seamfit.opt.coarse_start), adjoint method only.
    coarse_edge_length_cm: float = setting(
        DEFAULT_EDGE_LENGTH_CM, "a mesh at least twice as fine is graded at this edge length first and searched "
        "from there (0: every mesh graded directly)", unit="cm", low=0, flag="--coarse-edge-length",
        metavar="CM", commands=GRADE)
    fine_outer_iterations: int = setting(
        0, "outer iterations on the finer mesh after its coarse grading", low=0, flag="--fine-iterations",
        metavar="N", commands=GRADE)
    sdf_spacing: float = setting(
        0.0025, "spacing of the bodies' signed distance fields (the paper's 2.5 mm)", unit="m", low=0,
        low_open=True, flag="--sdf-spacing", metavar="M", commands=GRADE + DRAPE,
        addon=Addon("sdf_spacing_mm", "Body grid (mm)", scale=1000.0, minimum=0.5, soft_max=20.0, precision=2))
    # docs/grading.md, "The body fields' region"
    sdf_region: str = setting(
        "auto", "where the body fields are built: body (the whole body), garment (cut to the garment's height "
        "band plus --sdf-margin: fine spacings for fine meshes) or auto (the whole body unless its grid would "
        "exceed the SDF builder's node limit)", choices=SDF_REGIONS, flag="--sdf-region",
        commands=GRADE)
    sdf_region_margin: float = setting(
        GARMENT_REGION_MARGIN, "with a cropped field, how far above and below the garment it reaches", unit="m",
        low=0, flag="--sdf-margin", metavar="M", commands=GRADE)
    inner_iterations: int = setting(
        8, "S: simulation iterations per outer iteration", low=1, flag="--inner-iterations", short="-S",
        metavar="S", commands=GRADE, addon=Addon("steps_per_iteration", "S (simulation steps)", soft_max=256))
    min_inner_iterations: int = 2      # S never halves below this after an accepted checkpoint
    checkpoint_every: int = setting(
        32, "M: an exact simulation every M outer iterations", low=1, flag="--checkpoint-every", short="-M",
        metavar="M", commands=GRADE, addon=Addon("exact_every", "M (exact every)", soft_max=256))
    # The knee of run time against error on the shared cases (docs/accuracy_time.md): past
    # 128 the search converges more cases and ends farther from the drafts.
    max_outer_iterations: int = setting(
        128, "most outer iterations of the search", low=0, flag="--max-iterations", metavar="N", commands=GRADE,
        addon=Addon("iterations", "Outer iterations", minimum=1, soft_max=4096))
    stop_move_mm: float = setting(
        0.1, "stop once a checkpoint moved no pattern point more than this since the one before (0: run to "
        "the objective's own stop or the budget)", unit="mm", low=0, flag="--stop-move-mm", metavar="MM",
        commands=GRADE)
    bandwidth: float = DEFAULT_BANDWIDTH      # B of Eq. 15 (m)
    # One more drape, 1.4 s of a 60K-triangle grading on an H100, that changes no result.
    evaluate_base_pattern: bool = setting(
        False, "also drape the unchanged base pattern on the target body and report its objective "
        "(objective_base_pattern; one more drape)", flag="--report-base-pattern", commands=GRADE)
    time_budget_s: float = setting(
        0.0, "stop after this many seconds (0: no limit)", unit="s", low=0, flag="--time-budget", metavar="S",
        commands=GRADE)
    device: str = setting(
        "auto", "where the simulations and the search run: auto (the GPU when one is present and the garment is "
        "large enough to pay), cpu or cuda (fails at once with the reason when no GPU or CUDA build is present)",
        choices=("auto", "cpu", "cuda"), flag="--device", commands=GRADE + DRAPE,
        choice_labels=("Auto", "CPU", "CUDA"), choice_help=("The GPU for large garments when one is present, otherwise the CPU", "Run on the processor",
                     "Simulate, solve the adjoint and evaluate the costs on the NVIDIA GPU (stops with the "
                     "reason if none can be used)"),
        addon=Addon("device", "Device"))
    # Inexact Newton's forcing rule: MINRES to max(1e-8, adjoint_forcing * residual) at
    # inexact states, 1e-8 at settled ones (docs/gpu_backend.md, "The adjoint on the GPU").
    adjoint_forcing: float = setting(
        0.01, "on the GPU, solve the adjoint at inexact states only to this times the state's residual (0: to "
        "1e-8 everywhere, as the CPU's direct solve, 4x slower at 60K triangles)", low=0, high=1,
        high_open=True, flag="--adjoint-forcing", metavar="F", commands=GRADE)

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
        """SolveError naming the setting outside its choices or range (seamfit.settings)."""
        try:
            check_fields(self, "grade")
        except ValueError as exc:
            raise SolveError(str(exc)) from None

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
