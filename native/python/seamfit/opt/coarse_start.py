"""Coarse-to-fine grading: a mesh at least twice as fine as the coarse level (3 cm by
default) is graded there, and the result is carried to it.

A grading's cost grows with the mesh (the search's outer iteration about as n^2 on the
CPU, linearly on the GPU, and a fine base drape can stagnate), while its landmark error
does not fall below the 3 cm default's (docs/accuracy_time.md). So the whole grading -
base drape, level scaling, Section 7's initialization and the search - runs on the coarse
mesh; the fine mesh takes the graded pattern, carried through the base pattern's
coordinates (``carry_pattern``), and one exact drape of it on the target, warm-started
from the coarse drape carried over. It is searched further only when asked
(``GradeSettings.fine_outer_iterations``; measured not to help, docs/grading.md).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..sim.multilevel import COARSENING, locate
from ..device_arrays import host


@dataclass
class CoarseGrading:
    """What the coarse level hands on: its mesh, its graded pattern (every vertex,
    metres) and drape, and how its search went."""
    mesh: object
    pattern_m: np.ndarray
    x: np.ndarray
    xbar: np.ndarray
    report: dict              # its search and its seconds, for the grading's report
    warm_start: dict


def coarse_edge_for(settings) -> float:
    """The coarse level's edge (cm) for ``settings``, or 0 where the mesh is graded
    directly: the adjoint method on a mesh at least COARSENING times finer than
    ``settings.coarse_edge_length_cm`` (0: never)."""
    coarse = float(settings.coarse_edge_length_cm or 0.0)
    if coarse <= 0 or settings.method != "adjoint":
        return 0.0
    return coarse if COARSENING * float(settings.edge_length_cm) <= coarse + 1e-9 else 0.0


def coarse_settings(settings):
    """``settings`` at the coarse level: its edge, graded directly."""
    return replace(settings, edge_length_cm=coarse_edge_for(settings), coarse_edge_length_cm=0.0)


def fine_settings(settings):
    """``settings`` on the fine mesh after its coarse level: fine_outer_iterations at most."""
    return replace(settings, max_outer_iterations=min(settings.max_outer_iterations,
                                                      settings.fine_outer_iterations))


def grade_coarse(base_pattern, base_body, target_body, settings, *, fabric=None, sim_settings=None,
                 progress=None, warm_start=None, shared=None) -> CoarseGrading:
    """Algorithm 1 on the pattern meshed at ``coarse_edge_for(settings)``, every other
    setting as given; its events reach ``progress`` as the stage "coarse grading"."""
    from .grade import algorithm1
    from .prepare import prepare

    t0 = time.perf_counter()
    coarse = coarse_settings(settings)

    def relay(info):
        if progress is None:
            return None
        # The coarse level's own stages are one stage of the whole grading.
        return progress({"stage": "coarse grading", "detail": info.get("stage")})

    ctx = prepare(base_pattern, base_body, target_body, coarse, fabric=fabric,
                  sim_settings=sim_settings, progress=relay, shared=shared)
    if warm_start is not None:
        ctx.extra["warm_start"] = warm_start
    out = algorithm1(ctx)
    pattern_m = np.array(host(ctx.param.pattern(out.theta)), dtype=float)
    report = {"edge_length_cm": coarse.edge_length_cm, "vertices": int(ctx.mesh.n_vertices),
              "outer_iterations": int(out.iterations), "outer_iterations_done": int(out.iterations_done),
              "converged": bool(out.converged), "message": out.message,
              "objective_initial": float(out.checkpoints[0]["objective"]) if out.checkpoints else None,
              "objective_final": float(out.checkpoints[-1]["objective"]) if out.checkpoints else None,
              "seconds_loop": float(out.seconds_loop), "base_drape": ctx.base_info,
              "warm_start": warm_start is not None}
    warm = {"theta_init": np.array(ctx.extra["theta_init"], dtype=float),
            "theta": np.array(host(out.theta), dtype=float)}
    report["seconds"] = time.perf_counter() - t0
    return CoarseGrading(mesh=ctx.mesh, pattern_m=pattern_m, x=np.array(host(out.x), dtype=float),
                         xbar=np.array(ctx.xbar, dtype=float), report=report, warm_start=warm)


def carry_pattern(coarse_mesh, coarse_pattern_m: np.ndarray, fine_mesh) -> np.ndarray:
    """The fine mesh's vertices (N_fine, 2, metres) in the coarse level's graded pattern.

    Boundary vertices (the parameters theta) take the coarse boundary's displacement from
    the base pattern, interpolated along each stretch of outline between two corners by
    its share of the stretch's length, by cubic Hermite pieces (C1): the outline has no kinks
    at the coarse vertices (piecewise-linear displacements made R^cur 300 times the graded
    pattern's on a 1.5 cm mesh). Interior vertices, and any loop whose corners the two
    meshes do not share, take the displacement of their place in the coarse mesh (linear in
    the coarse triangle holding it). The displacement is carried, not the position, so a
    fine curve keeps its own bulge between two coarse vertices instead of their chord."""
    base_c = np.asarray(coarse_mesh.uv_cm, dtype=float) / 100.0
    base_f = np.asarray(fine_mesh.uv_cm, dtype=float) / 100.0
    move_c = np.asarray(coarse_pattern_m, dtype=float).reshape(-1, 2) - base_c
    tri, bary = locate(coarse_mesh, fine_mesh.uv_cm, fine_mesh.vertex_panel)
    move_f = np.einsum("mi,mij->mj", bary, move_c[coarse_mesh.triangles[tri]])
    for loop_c, loop_f in zip(_loops(coarse_mesh), _loops(fine_mesh)):
        along = _along_outline(loop_c, loop_f, base_c, base_f, np.asarray(coarse_mesh.corner, bool),
                               np.asarray(fine_mesh.corner, bool), move_c)
        if along is not None:
            move_f[loop_f] = along
    return base_f + move_f


def _loops(mesh) -> list:
    """One boundary loop per panel (None for a panel with several: holes)."""
    out = []
    for entry in mesh.boundary_loops:
        several = isinstance(entry, (list, tuple)) and len(entry) > 0 and not np.isscalar(entry[0])
        out.append(None if several else np.asarray(entry, dtype=np.int64))
    return out


def _along_outline(loop_c, loop_f, base_c, base_f, corner_c, corner_f, move_c):
    """Displacements of the fine loop's vertices, interpolated stretch by stretch between
    the corners both loops share; None where the loops cannot be matched so."""
    if loop_c is None or loop_f is None:
        return None
    kc = np.flatnonzero(corner_c[loop_c])
    kf = np.flatnonzero(corner_f[loop_f])
    if len(kc) < 1 or len(kc) != len(kf):
        return None
    # Corners are sampled from the same outline points: match them by position.
    pos_c = base_c[loop_c[kc]]
    pos_f = base_f[loop_f[kf]]
    d = np.linalg.norm(pos_f[:, None, :] - pos_c[None, :, :], axis=2)
    match = d.argmin(axis=1)
    if np.any(d[np.arange(len(kf)), match] > 1e-6) or len(set(match.tolist())) != len(kf):
        return None
    out = np.empty((len(loop_f), 2))
    nc, nf = len(loop_c), len(loop_f)
    for j in range(len(kf)):
        f0, f1 = kf[j], kf[(j + 1) % len(kf)]
        c0 = kc[match[j]]
        c1 = kc[match[(j + 1) % len(kf)]]
        idx_f = np.arange(f0, f0 + ((f1 - f0) % nf or nf) + 1) % nf
        idx_c = np.arange(c0, c0 + ((c1 - c0) % nc or nc) + 1) % nc
        if not np.allclose(base_f[loop_f[idx_f[-1]]], base_c[loop_c[idx_c[-1]]], atol=1e-6):
            return None       # the loops run opposite ways
        tc, tf = _share(base_c[loop_c[idx_c]]), _share(base_f[loop_f[idx_f]])
        mv = move_c[loop_c[idx_c]]
        out[idx_f] = _hermite(tc, mv, tf)
    return out


def _hermite(t: np.ndarray, y: np.ndarray, tq: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite interpolation of y (n, 2) at t (increasing) evaluated at tq,
    with each knot's slope the three-point derivative of the non-uniform grid (exact for a
    parabola; one-sided at the ends): C1, so no kinks at the knots. (NumPy only: the Blender
    extension ships SciPy without its interpolation package.)"""
    t, y = np.asarray(t, float), np.asarray(y, float)
    h = np.diff(t)
    d = np.diff(y, axis=0) / h[:, None]                     # secant slopes
    m = np.empty_like(y)
    m[0], m[-1] = d[0], d[-1]
    if len(t) > 2:
        m[1:-1] = (h[1:, None] * d[:-1] + h[:-1, None] * d[1:]) / (h[:-1] + h[1:])[:, None]
    k = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
    s = ((tq - t[k]) / h[k])[:, None]
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    return h00 * y[k] + h10 * h[k, None] * m[k] + h01 * y[k + 1] + h11 * h[k, None] * m[k + 1]


def _share(points: np.ndarray) -> np.ndarray:
    """Each point's share of the polyline's length from its start (0 .. 1)."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(points))
