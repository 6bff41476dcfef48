"""What every grading method shares before its search: the sewn mesh, both bodies' SDFs,
the base garment x-bar on the base body, the transferred garment x-tilde (Eq. 15), the
parametrization, regularizers, the grading objective f with the preset strengths, and the
simulator on the target body."""
from __future__ import annotations

import functools
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from .. import preload
from ..cache import cache_root, content_key, load_arrays, save_arrays
from ..device import choose_device
from ..errors import SolveError
from ..mesh import build_sewn_mesh
from ..pattern import Pattern, check_pattern
from ..sim.model import Fabric, SimSettings, Simulator
from ..sim.multilevel import prolong
from .adjoint import AdjointSolver
from .costs import CostSet, Strengths
from .objective import Objective
from .parametrization import Parametrization
from .regularizers import Regularizers
from .coarse_start import carry_pattern
from .level_scale import level_scaled_pattern, measure_ahead
from .seam import SeamLength
from .sdf_region import (body_field, garment_outside_field, placement_z_range,
                         resolve_sdf_region)
from .transfer import transfer_garment

ProgressFn = Callable[[dict], Optional[bool]]

# The base drape's cache version. -3: a drape the GPU made before it followed the CPU's
# solver rules may sit elsewhere. -4: the start positions no longer go through BLAS
# (seamfit.sim.dressing), so a flare settles into the same folds on every machine; a drape
# cached before may hold others.
DRAPE_CACHE_VERSION = "base-drape-4"


def base_drape(mesh, pattern, body, sdf, fabric: Fabric, settings: SimSettings, *, progress=None,
               refresh: bool = False, accept_unsettled: bool = False):
    """x-bar, the base garment on the base body, cached on disk by content
    (refresh: drape afresh and overwrite the cached one). A drape that does not settle
    raises SolveError, unless accept_unsettled (timing benchmarks of meshes the solver
    cannot settle, tests/benchmarks/measure_switches.py): then it is returned, not cached,
    with converged False in its info."""
    from ..sim.multilevel import drape_coarse_to_fine
    # The device is not an input of the physics: a drape made on the GPU serves the CPU too.
    physics = {k: v for k, v in asdict(settings).items() if k != "device"}
    # A field built on the GPU holds exact nearest distances, the CPU's propagated ones differ
    # by a fraction of a millimetre at a few nodes: a drape keeps to the field it settled on
    # (the CPU's key is the same as before the GPU build existed).
    field = (sdf.info.get("device"),) if sdf.info.get("device") == "cuda" else ()
    key = content_key(DRAPE_CACHE_VERSION, mesh.cache_key(), body.vertices, body.faces, float(sdf.spacing),
                      asdict(fabric), physics, *field)
    hit = None if refresh else load_arrays("drape", key, expect={"x": mesh.x0.shape})
    if hit is not None and hit["x"].shape == mesh.x0.shape:
        return hit["x"], {"cached": True, "key": key, **{k: float(hit[k]) for k in ("residual", "seconds")}}
    sim = Simulator(mesh, sdf, fabric, settings)
    # As `seamfit drape` does: a settle that stagnates restarts from a coarser drape.
    res = drape_coarse_to_fine(sim, pattern, mode="auto", progress=progress)
    if res.cancelled:
        raise SolveError("cancelled while draping the base garment")
    if not res.converged and accept_unsettled:
        return res.x, {"cached": False, "key": key, "converged": False, "residual": res.residual,
                       "seconds": res.seconds, "iterations": res.iterations, "message": res.message}
    if not res.converged:
        edge_mm, spacing_mm = 10.0 * float(mesh.edge_length_cm), 1000.0 * float(sdf.spacing)
        # Measured at 150K triangles: 2.85 mm edges plateau on a 2.5 mm field, settle on 1.8 mm
        # (docs/gpu_backend.md, "What stands between the measurements and the aims").
        hint = (f"; the mesh's edges ({edge_mm:.2g} mm) are near the body field's spacing ({spacing_mm:.2g} mm): "
                f"a finer SDF spacing may let it settle" if edge_mm < 2 * spacing_mm else "")
        raise SolveError(f"the base garment did not settle on the base body: {res.message} "
                         f"(residual {res.residual:.3g}); raise max_iterations or check the placement{hint}")
    save_arrays("drape", key, {"x": res.x, "residual": np.float64(res.residual), "seconds": np.float64(res.seconds)})
    stages = [{k: st.get(k) for k in ("stage", "iterations", "seconds", "residual", "converged", "linear_iterations",
                                      "device", "message")} for st in res.stages]
    return res.x, {"cached": False, "key": key, "residual": res.residual, "seconds": res.seconds,
                   "iterations": res.iterations, "max_sewing_gap_mm": res.max_sewing_gap_mm,
                   "min_phi_mm": res.min_phi_mm, "stages": stages}


@dataclass
class GradeContext:
    """Inputs and shared machinery of one grading run (built by ``prepare``)."""
    base_pattern: Pattern
    base_body: object
    target_body: object
    settings: object                  # GradeSettings
    strengths: Strengths              # the preset's: every method is scored with these
    mesh: object
    base_sdf: object
    target_sdf: object
    xbar: np.ndarray
    xtilde: np.ndarray
    base_info: dict
    param: Parametrization
    regs: Regularizers
    costs: CostSet                    # the grading objective's costs (preset strengths)
    seam: SeamLength                  # R^seam (skipped when strengths.seam is 0)
    sim: Simulator                    # on the target body
    adjoint: AdjointSolver
    objective: Objective              # f with the preset strengths
    exact_tolerance: float
    progress: Optional[ProgressFn]
    t_start: float
    base_on_target: object = None     # exact drape of the unchanged pattern on the target
    objective_base: Optional[float] = None
    terms_base: Optional[dict] = None
    extra: dict = field(default_factory=dict)

    def tell(self, **info) -> None:
        if self.progress is not None and self.progress(info) is False:
            raise SolveError("cancelled")

    def sim_progress(self, stage):
        def cb(it, res):
            return None if self.progress is None else self.progress({"stage": stage, "sim_iteration": it,
                                                                      "residual": res})
        return cb

    def exact(self, theta, x_start, stage):
        """The drape of p(theta) on the target body, warm-started at x_start, solved to the
        exact tolerance within the simulator's iteration budget (at 60K triangles the
        budget ends first: docs/gpu_backend.md, "What stands between")."""
        self.sim.set_pattern(self.param.pattern(theta))
        res = self.sim.solve(x_start, tolerance=self.exact_tolerance, progress=self.sim_progress(stage))
        if res.cancelled:
            raise SolveError("cancelled")
        return res

    def start_from_base_pattern(self):
        """The exact drape of the unchanged pattern on the target (computed once)."""
        if self.base_on_target is None:
            self.tell(stage="base pattern on target")
            self.base_on_target = self.exact(self.param.theta_bar, self.xtilde, "base pattern on target")
        return self.base_on_target


def prepare(base_pattern: Pattern, base_body, target_body, settings, *, fabric: Fabric | None = None,
            sim_settings: SimSettings | None = None, progress: ProgressFn | None = None,
            shared: dict | None = None, coarse=None) -> GradeContext:
    """Mesh, SDFs, x-bar, x-tilde and the grading objective; with
    ``settings.evaluate_base_pattern`` (or a baseline method) also the objective of the unchanged
    pattern on the target.
    ``shared``: a dict kept across the calls of one size run (same base pattern, base body,
    settings and fabric), holding what depends only on the base.
    ``coarse``: the coarse level of a coarse-to-fine grading (seamfit.opt.coarse_start.CoarseGrading):
    its graded pattern, carried to this mesh, is the start and the regularizers' anchor; with no
    outer iterations on this mesh its base drape, carried too, stands in for x-bar (the search
    that needs a settled one does not run)."""
    from ..body import check_body

    t_start = time.perf_counter()
    fabric = fabric or Fabric()
    sim_settings = sim_settings or SimSettings()
    strengths = settings.resolved_strengths(base_pattern.garment_type)

    def tell(**info):
        if progress is not None and progress(info) is False:
            raise SolveError("cancelled")

    def once(key, make):
        if shared is None:
            return make()
        if key not in shared:
            shared[key] = make()
        return shared[key]

    check_pattern(base_pattern)
    preload.want("scipy.optimize")      # the curve refit, at the end (seamfit.preload)
    if settings.start == "level":
        # The level scaling measures both bodies right after the fields (0.1-0.3 s each)
        preload.want(functools.partial(measure_ahead, base_body, target_body), first=True)
    tell(stage="mesh")
    mesh = once("mesh", lambda: build_sewn_mesh(base_pattern, edge_length_cm=settings.edge_length_cm))
    # Where the simulations and the adjoint solve run: auto takes the device this machine
    # was measured to run the simulator faster on at this size (seamfit.device).
    device_choice = choose_device(settings.device, problem_size=int(mesh.n_vertices))
    device = device_choice["device"]
    if device != sim_settings.device:
        sim_settings = replace(sim_settings, device=device)
    tell(stage="sdf")
    # Each body's field over its whole box, or cut to the garment's height band where that
    # grid would be too large (sdf_region; docs/grading.md, "The body fields' region").
    region = settings.sdf_region
    margin = settings.sdf_region_margin
    base_region = resolve_sdf_region(region, base_body, settings.sdf_spacing)
    target_region = resolve_sdf_region(region, target_body, settings.sdf_spacing)
    base_sdf, base_field = once("base_field", lambda: body_field(
        base_body, settings.sdf_spacing, base_region, margin=margin,
        z_range=placement_z_range(mesh, base_pattern, base_body) if base_region == "garment" else None,
        device=device))
    if target_region == "body":
        target_sdf, target_field = body_field(target_body, settings.sdf_spacing, "body", device=device)
    else:
        check_body(target_body)  # fail before the base drape, as the whole-body build would

    tell(stage="base drape")

    def drape_progress(it, res):
        return None if progress is None else progress({"stage": "base drape", "sim_iteration": it, "residual": res})

    if coarse is not None and settings.max_outer_iterations == 0:
        xbar = prolong(coarse.mesh, coarse.xbar, mesh)
        base_info = {"cached": False, "carried": "the coarse level's base drape, carried to this mesh",
                     "coarse_edge_length_cm": float(coarse.mesh.edge_length_cm)}
    else:
        xbar, base_info = once("base_drape", lambda: base_drape(
            mesh, base_pattern, base_body, base_sdf, fabric, sim_settings, progress=drape_progress))
    problem = garment_outside_field(base_sdf, base_field, xbar, "base", "at the end of the base drape")
    if problem:
        if not base_info.get("cached") and "key" in base_info:
            # Its cache key holds the field's spacing, not its box: a drape that left the
            # field must not be served to the next run (with sdf_region "body", say).
            (cache_root() / "drape" / f"{base_info['key']}.npz").unlink(missing_ok=True)
        raise SolveError(problem)
    tell(stage="transfer")
    xtilde = transfer_garment(xbar, base_body, target_body, settings.bandwidth)
    if target_region == "garment":
        # The target's region follows x-tilde, the garment on the target body: the search
        # starts from it and its positional cost pulls the drape towards it.
        tell(stage="sdf")
        target_sdf, target_field = body_field(target_body, settings.sdf_spacing, "garment", margin=margin,
                                              z_range=(float(xtilde[:, 2].min()), float(xtilde[:, 2].max())),
                                              device=device)

    param = Parametrization(mesh)
    if device == "cuda":
        param.use_device("cuda")
    # The measurement-aware start: theta^(0) and the anchor of R^fix and R^cur
    # (docs/method.md, "Level scaling"); "base" is the paper's (Section 7 from theta-bar).
    theta_level = None
    start = {"from": "base pattern"}
    if coarse is not None:
        theta_level = param.theta_of(carry_pattern(coarse.mesh, coarse.pattern_m, mesh))
        start = {"from": "coarse level", "coarse_edge_length_cm": float(coarse.mesh.edge_length_cm)}
    elif settings.start == "level":
        tell(stage="level scaling")
        p_level, info = level_scaled_pattern(mesh, xbar, base_body, target_body, base_sdf, return_info=True)
        theta_level = param.theta_of(p_level)
        # what the start measured, for the report: panels graded around the arm, and
        # whether the seat line moved with the body's waist-to-hip or a flare hangs from the
        # natural waist
        start = {"from": "level scaling", "sleeve_panels": info["sleeve_panels"], "seat_line": info["seat_line"],
                 "natural_waist": info["natural_waist"]}
    # R^fix is in f (the paper) and shapes the preconditioner (docs/grading.md).
    regs = Regularizers(param, strengths.fix, strengths.cur, anchor=theta_level)
    seam = SeamLength(param, mesh, strengths.seam)
    if seam.active:   # R^seam's Gauss-Newton Hessian at the base joins P (docs/optimizer.md)
        regs.add_to_preconditioner(seam.gauss_newton())
    if device == "cuda":
        # R^fix + R^cur, R^seam and P^-1 too; P^-1 stays on the CPU, with the reason in
        # regs.device_note, when it would not fit (docs/gpu_backend.md).
        regs.use_device("cuda")
        seam.use_device("cuda")
    costs = CostSet(mesh, xbar, strengths, target_sdf=target_sdf, base_sdf=base_sdf, xtilde=xtilde)
    if device == "cuda":
        costs.use_device("cuda")
    sim = Simulator(mesh, target_sdf, fabric, sim_settings)
    exact_tolerance = sim_settings.tolerance
    # An unconverged GPU adjoint solve at a state within 10x the exact tolerance falls
    # back to the CPU; further out it keeps MINRES's iterate (seamfit.opt.adjoint).
    adjoint = AdjointSolver(sim, device=device, equilibrium_tolerance=10 * exact_tolerance,
                            inexact_forcing=settings.adjoint_forcing)
    ctx = GradeContext(
        base_pattern=base_pattern, base_body=base_body, target_body=target_body, settings=settings,
        strengths=strengths, mesh=mesh, base_sdf=base_sdf, target_sdf=target_sdf, xbar=xbar, xtilde=xtilde,
        base_info=base_info, param=param, regs=regs, costs=costs, seam=seam, sim=sim, adjoint=adjoint,
        objective=Objective(param, regs, costs, sim, adjoint, seam),
        exact_tolerance=exact_tolerance, progress=progress, t_start=t_start)
    ctx.extra["sdf"] = {"requested": region, "base": base_field, "target": target_field}
    ctx.extra["theta_level"] = theta_level
    ctx.extra["start"] = start
    ctx.extra["device_choice"] = device_choice
    ctx.extra["shared"] = shared
    if settings.drapes_base_pattern:
        # the baselines start from this drape, so its objective costs them one evaluation
        rb = ctx.start_from_base_pattern()
        ctx.objective_base, ctx.terms_base = ctx.objective.objective(rb.x, param.theta_bar)
    return ctx

