"""Coarse-to-fine dressing: where a garment does not settle on its mesh, drape
the same pattern on a coarser mesh and carry that drape to the fine mesh
through pattern coordinates.

Block-Jacobi iterations remove the unbalanced force of short wavelengths fast
and that of long ones slowly (their count grows with the number of edges across
a panel); a garment that hangs free over a large area (a circle skirt's flare)
still moves as a whole long after its seams have closed. On a mesh of twice
the edge length the same motion takes a quarter of the vertices and about half
the iterations. The coarse drape is then prolonged: every fine vertex takes the
position of its pattern point (u, v) inside the coarse triangle of the same
panel (linear interpolation), which is where the coarse drape put that point of
the cloth. The fine solve starts with the seams closed and the garment on the
body, and only the short wavelengths the coarse mesh could not carry are left.
"""
from __future__ import annotations

import numpy as np

from ..errors import SeamfitError


def locate(coarse, uv: np.ndarray, panel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The coarse triangle of the same panel holding each pattern point uv (cm),
    and the point's barycentric coordinates in it, (M,) and (M, 3). Points just
    outside the coarse outline (a curved edge sampled at different points) take
    the nearest triangle, their coordinates clamped onto it."""
    from scipy.spatial import cKDTree

    uv = np.asarray(uv, dtype=np.float64)
    tri_out = np.zeros(len(uv), dtype=np.int64)
    bary = np.zeros((len(uv), 3))
    for k in np.unique(panel):
        rows = np.where(panel == k)[0]
        tids = np.where(coarse.triangle_panel == k)[0]
        if len(tids) == 0:
            raise SeamfitError(f"panel {k} has no triangles on the coarse mesh")
        corners = coarse.uv_cm[coarse.triangles[tids]]            # (T, 3, 2)
        q = uv[rows]
        cand = min(8, len(tids))
        _, near = cKDTree(corners.mean(axis=1)).query(q, k=cand)
        near = near.reshape(len(q), cand)
        a, b, c = corners[near, 0], corners[near, 1], corners[near, 2]
        e1, e2, r = b - a, c - a, q[:, None, :] - a
        det = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]
        det = np.where(np.abs(det) > 1e-300, det, 1e-300)
        l1 = (r[..., 0] * e2[..., 1] - r[..., 1] * e2[..., 0]) / det
        l2 = (e1[..., 0] * r[..., 1] - e1[..., 1] * r[..., 0]) / det
        lam = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)          # (M, cand, 3)
        best = np.argmax(lam.min(axis=-1), axis=1)                 # inside, or least outside
        pick = np.arange(len(q))
        lb = np.clip(lam[pick, best], 0.0, None)
        lb /= np.maximum(lb.sum(axis=1, keepdims=True), 1e-300)
        tri_out[rows] = tids[near[pick, best]]
        bary[rows] = lb
    return tri_out, bary


def prolong(coarse, x_coarse: np.ndarray, fine) -> np.ndarray:
    """Positions (N_fine, 3) of the fine mesh's vertices from a drape of the
    coarse mesh of the same pattern, through pattern coordinates."""
    if list(coarse.panel_names) != list(fine.panel_names):
        raise SeamfitError("coarse and fine meshes are not of the same pattern (panels differ)")
    tri, bary = locate(coarse, fine.uv_cm, fine.vertex_panel)
    xc = np.asarray(x_coarse, dtype=np.float64).reshape(-1, 3)
    return np.einsum("mi,mij->mj", bary, xc[coarse.triangles[tri]])


# Each level doubles the edge length: a quarter of the vertices, and the
# slowest wavelength spans half as many edges.
COARSENING = 2.0


def coarse_mesh(pattern, fine):
    """The pattern meshed at COARSENING times fine's edge length, or None where
    that cannot be built (a panel too narrow) or is no coarser."""
    from ..errors import PatternError
    from ..mesh import build_sewn_mesh

    try:
        coarse = build_sewn_mesh(pattern, COARSENING * float(fine.edge_length_cm))
    except PatternError:
        return None
    return coarse if coarse.n_vertices < fine.n_vertices else None


def drape_from_coarse(sim, pattern, coarse, mode: str = "auto", progress=None, device=None):
    """Dress the coarse mesh of `pattern` with sim's fabric and settings (stages
    "coarse sew", "coarse settle", "coarse polish"), prolong its drape to
    sim.mesh and settle and polish it there ("prolonged settle", "polish")."""
    from .dressing import initial_positions
    from .model import Simulator

    done = [0]

    def relay(it, res):
        return True if progress is None else progress(done[0] + it, res)

    x0c, _ = initial_positions(coarse, pattern, sim.sdf, mode=mode)
    rc = Simulator(coarse, sim.sdf, sim.fabric, sim.settings).drape(x0c, progress=relay, device=device)
    stages = [dict(s, stage="coarse " + s["stage"], vertices=int(coarse.n_vertices),
                   edge_length_cm=float(coarse.edge_length_cm)) for s in rc.stages]
    x = prolong(coarse, rc.x, sim.mesh)
    if rc.cancelled:
        return sim._result(sim.project_outside(x)[0], stages)
    done[0] = rc.iterations
    # Gaps the interpolation leaves between coarse seam vertices are closed
    # under gravity; a sew stage (gravity off) would let the drape float.
    rf = sim.drape(x, progress=relay, device=device, sewn=True)
    stages += [dict(s, stage="prolonged settle" if s["stage"] == "settle" else s["stage"]) for s in rf.stages]
    return sim._result(rf.x, stages)


def drape_coarse_to_fine(sim, pattern, mode: str = "auto", progress=None, device=None):
    """Dress sim's garment (sim.mesh, built from `pattern`); where its settle
    stagnates, start again from a drape at COARSENING times the edge length.

    First the usual drape from the start positions
    (seamfit.sim.dressing.initial_positions with `mode`) without the polish:
    a garment that settles is done, at the cost it always had. Otherwise
    drape_from_coarse; where that does not converge, the first settle is
    polished too (stage "polish of the first settle") and the better state is
    handed back (converged, else less residual), so the restart only adds
    converged drapes. Where no coarse mesh can be built the first settle is
    polished as usual.
    """
    from .dressing import initial_positions

    x0, _ = initial_positions(sim.mesh, pattern, sim.sdf, mode=mode)
    direct = sim.drape(x0, progress=progress, device=device, polish=False)
    if direct.converged or direct.cancelled or sim.settings.method != "chebyshev":
        return direct
    coarse = coarse_mesh(pattern, sim.mesh)
    if coarse is None:
        if not sim.settings.polish:
            return direct
        rp = sim.polish(direct.x, progress=progress)
        return sim._result(rp.x, direct.stages + rp.stages)

    def relay(it, res):
        return True if progress is None else progress(direct.iterations + it, res)

    rf = drape_from_coarse(sim, pattern, coarse, mode, relay, device)
    stages = direct.stages + rf.stages
    if rf.converged or rf.cancelled:
        return sim._result(rf.x, stages)
    # Newton's path from a stagnated settle is erratic (docs/simulator.md): the
    # first settle's state gets its own polish before the restart is given up.
    if sim.settings.polish:
        before = direct.iterations + rf.iterations
        rp = sim.polish(direct.x, progress=None if progress is None else lambda it, res: progress(before + it, res))
        stages += [dict(s, stage="polish of the first settle") for s in rp.stages]
        other, label = rp, None
    else:
        other, label = direct, "the first settle's"
    last = other if label is None else rf
    best = other if (other.converged or other.residual < rf.residual) else rf
    if best is not last:
        whose = "the restart's" if best is rf else label
        stages[-1] = dict(stages[-1], residual=best.residual, converged=best.converged,
                          message=stages[-1]["message"] + f"; handed back {whose} state "
                          f"(relative residual {best.residual:.3g})")
    return sim._result(best.x, stages)
