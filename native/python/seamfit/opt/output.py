"""What every grading method shares after its search: the adjusted pattern (panels
rotated back onto their grain, curves refitted), output checks, ease, the grading
objective at start and end, and the report."""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Optional

import numpy as np

from ..mesh import outline_from_uv
from ..pattern import Pattern
from ..pattern.checks import output_checks
from ..pattern.markings import carry_markings
from ..settings import echo
from ..pattern.darts import true_darts
from ..pattern.sectors import true_sectors
from ..pattern.refit import refit_pattern
from ..pattern.symmetry import find_symmetries, symmetrize, symmetry_report
from .fit import ease_losses, ease_report


@dataclass
class SearchOutcome:
    """What a method's search hands to ``finish``: its final pattern parameters and
    exact drape, its start, and how it went."""
    theta: np.ndarray                  # final boundary parameters (n_theta, 2) m
    x: np.ndarray                      # exact drape of p(theta) on the target body
    theta_start: np.ndarray            # where the search started
    x_start: np.ndarray                # and that pattern's exact drape
    iterations: int
    iterations_done: int
    converged: bool
    message: str
    checkpoints: list                  # accepted exact states: iteration, objective (grading f), search_objective
    cost_evaluations: dict             # evaluations of each cost term by the search itself
    history: dict
    seconds_loop: float
    backtracks: int = 0
    initialization: Optional[dict] = None
    details: dict = field(default_factory=dict)   # method-specific report entries


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
    # Adjoint method: its initialization and final parameters, a neighbouring size's warm start
    warm_start: Optional[dict] = None


def remove_panel_rotations(mesh, uv_new_cm: np.ndarray) -> tuple[np.ndarray, dict]:
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


def mismatch_mm(x, xtilde) -> float:
    """RMS distance (mm) between a garment and the transferred garment x-tilde: how far
    the inverse pattern design problem (Eq. 3) is from solved."""
    d = np.linalg.norm(np.asarray(x, float) - np.asarray(xtilde, float), axis=1)
    return float(1000.0 * np.sqrt(np.mean(d * d))) if len(d) else 0.0


@dataclass
class AdjustedPattern:
    """The pattern a grading hands the user, made from the mesh's new pattern coordinates."""
    refit: object                      # seamfit.pattern.refit.RefitResult; .pattern is the result
    uv_cm: np.ndarray                  # every mesh vertex, panels turned back onto their grain
    uv_marks_cm: np.ndarray            # the same, trued panels through their truing map (markings)
    rotations: dict
    symmetries: list
    symmetry_moves: dict
    dart_moves: dict
    sector_moves: dict


def adjusted_pattern(base_pattern, mesh, uv_raw_cm: np.ndarray) -> AdjustedPattern:
    """The adjusted pattern from new mesh coordinates (cm): each panel turned back onto the
    base's grain, symmetries restored, straight darts and circle skirts trued, the curves
    refitted. Every grading and every benchmark that scores a search's state goes through
    this one path."""
    uv_new, rotations = remove_panel_rotations(mesh, uv_raw_cm)
    outlines = outline_from_uv(mesh, uv_new)
    # Symmetric panels and left/right pairs of the base stay so (docs/grading.md, "Symmetry").
    symmetries = find_symmetries(base_pattern)
    symmetry_moves = symmetrize(outlines, symmetries)
    # Straight dart legs come out of the refit as their chords; true them first.
    dart_moves = true_darts(base_pattern, outlines)
    # A circle skirt's panel keeps its drafted angle and stays a ring's sector. Its markings
    # go through the same map (the mesh itself stays the drape's rest shape).
    panel_of = np.asarray(mesh.vertex_panel)
    vertices = {name: np.flatnonzero(panel_of == k) for k, name in enumerate(mesh.panel_names)}
    sector_moves, sector_vertices = true_sectors(
        base_pattern, outlines, carry={name: mesh.uv_cm[idx] for name, idx in vertices.items()})
    uv_marks = uv_new.copy()
    for name, uv in sector_vertices.items():
        uv_marks[vertices[name]] = uv
    return AdjustedPattern(refit=refit_pattern(base_pattern, outlines), uv_cm=uv_new, uv_marks_cm=uv_marks,
                           rotations=rotations, symmetries=symmetries, symmetry_moves=symmetry_moves,
                           dart_moves=dart_moves, sector_moves=sector_moves)


def finish(ctx, method: str, out: SearchOutcome) -> GradeResult:
    """The adjusted pattern, checks and report of a finished search."""
    settings, mesh, param, sim = ctx.settings, ctx.mesh, ctx.param, ctx.sim
    f0, terms0 = ctx.objective.objective(out.x_start, out.theta_start)
    f_final, terms_final = ctx.objective.objective(out.x, out.theta)

    adjusted = adjusted_pattern(ctx.base_pattern, mesh, 100.0 * param.pattern(out.theta))
    refit = adjusted.refit
    markings = carry_markings(ctx.base_pattern, refit.pattern, mesh, adjusted.uv_marks_cm)
    checks = output_checks(ctx.base_pattern, refit.pattern)

    shared = ctx.extra.get("shared")
    if shared is not None and "ease_base" in shared:
        ease_base = shared["ease_base"]
    else:
        ease_base = ease_report(ctx.base_body, ctx.xbar, mesh.triangles)
        if shared is not None:
            shared["ease_base"] = ease_base
    ease_result = ease_report(ctx.target_body, out.x, mesh.triangles)
    gaps = sim.sewing_gaps(out.x)
    phi = sim.phi(out.x)
    seconds_total = time.perf_counter() - ctx.t_start
    work = out.iterations_done
    report = {
        "method": method,
        "device": sim.settings.device,
        # why that device (auto: the measured speeds of this machine, seamfit.device)
        "device_choice": ctx.extra.get("device_choice"),
        # Where each part of the loop ran (the parametrization and the regularizers stay on
        # the CPU when their dense blocks / P^-1 would not fit in GPU memory, with the reason).
        "devices": {"simulation": sim.settings.device, "adjoint": ctx.adjoint.device,
                    "costs": ctx.costs.device, "parametrization": ctx.param.device,
                    **({"parametrization_note": ctx.param.device_note} if ctx.param.device_note else {}),
                    "regularizers": ctx.regs.device, "seam": ctx.seam.device,
                    **({"regularizers_note": ctx.regs.device_note} if ctx.regs.device_note else {})},
        "objective_base_pattern": ctx.objective_base,
        "objective_initial": f0,
        "objective_final": f_final,
        "objective_reduction": (f0 - f_final) / f0 if f0 > 0 else 0.0,
        "terms_base_pattern": ctx.terms_base,
        "terms_initial": terms0,
        "terms_final": terms_final,
        "mismatch_mm": {"initial": mismatch_mm(out.x_start, ctx.xtilde), "final": mismatch_mm(out.x, ctx.xtilde)},
        "strengths": asdict(ctx.strengths),
        "outer_iterations": out.iterations,
        "checkpoints": out.checkpoints,
        "cost_evaluations": dict(out.cost_evaluations),
        "outer_iterations_done": work,
        "backtracks": out.backtracks,
        "converged": out.converged,
        "message": out.message,
        "seconds_total": seconds_total,
        "seconds_precompute": seconds_total - out.seconds_loop,
        "seconds_loop": out.seconds_loop,
        "seconds_per_iteration": out.seconds_loop / max(work, 1),
        "max_displacement_mm": checks.get("max_displacement_mm"),
        "seam_mismatch_mm": {str(s_["index"]): s_["seam_mismatch_mm"] for s_ in checks.get("stitches", [])},
        "checks": checks,
        "refit": {"ok": refit.ok, "max_deviation_mm": refit.max_deviation_overall_mm,
                  "failed": [list(map(str, f_)) for f_ in refit.failed], "notes": refit.notes},
        "panel_rotation_removed_deg": adjusted.rotations,
        "symmetry": symmetry_report(refit.pattern, adjusted.symmetries, adjusted.symmetry_moves),
        "darts_trued_mm": {k: round(v, 3) for k, v in adjusted.dart_moves.items()},
        "sectors_trued_mm": {k: round(v, 3) for k, v in adjusted.sector_moves.items()},
        "markings": markings,
        "ease_cm": {"base": ease_base, "result": ease_result, "losses": ease_losses(ease_base, ease_result)},
        "drape": {"max_sewing_gap_mm": float(gaps.max() * 1000) if len(gaps) else 0.0,
                  "min_phi_mm": float(phi.min() * 1000)},
        "base_drape": ctx.base_info,
        "start": ctx.extra.get("start"),
        "initialization": out.initialization or {"objective_history": [], "message": "not used by this method"},
        "mesh": {"vertices": int(len(mesh.uv_cm)), "triangles": int(len(mesh.triangles)),
                 "edge_length_cm": settings.edge_length_cm},
        "settings": echo(settings, "grade"),    # the user's settings (seamfit.settings); strengths above
        **out.details,
    }
    return GradeResult(pattern=refit.pattern, uv_cm=adjusted.uv_cm, x=out.x, xbar=ctx.xbar, xtilde=ctx.xtilde, mesh=mesh,
                       report=report, history=out.history)
