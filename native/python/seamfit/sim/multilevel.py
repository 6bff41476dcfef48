"""Coarse-to-fine dressing: drape the same pattern on a coarser mesh first and
carry that drape to the fine mesh through pattern coordinates.

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


def drape_coarse_to_fine(sim, pattern, mode: str = "auto", progress=None, device=None):
    """Dress sim's garment (sim.mesh, built from `pattern`) starting from a
    drape of the same pattern at COARSENING times the edge length.

    The coarse drape runs with sim's fabric and settings from the usual start
    positions (seamfit.sim.dressing.initial_positions with `mode`); its stages
    are reported first, named "coarse sew", "coarse settle", "coarse polish".
    Where the coarse mesh cannot be built (a panel too narrow for the longer
    edge), the fine garment is dressed from its own start positions.
    """
    from ..errors import PatternError
    from ..mesh import build_sewn_mesh
    from .dressing import initial_positions
    from .model import Simulator

    fine = sim.mesh
    try:
        coarse = build_sewn_mesh(pattern, COARSENING * float(fine.edge_length_cm))
    except PatternError:
        coarse = None
    if coarse is None or coarse.n_vertices >= fine.n_vertices:
        x0, _ = initial_positions(fine, pattern, sim.sdf, mode=mode)
        return sim.drape(x0, progress=progress, device=device)
    x0c, _ = initial_positions(coarse, pattern, sim.sdf, mode=mode)
    csim = Simulator(coarse, sim.sdf, sim.fabric, sim.settings)
    rc = csim.drape(x0c, progress=progress, device=device)
    cstages = [dict(s, stage="coarse " + s["stage"], vertices=int(coarse.n_vertices),
                    edge_length_cm=float(coarse.edge_length_cm)) for s in rc.stages]
    x = prolong(coarse, rc.x, fine)
    if rc.cancelled:
        x, _ = sim.project_outside(x)
        return sim._result(x, cstages)
    done = rc.iterations

    def relay(it, res):
        return True if progress is None else progress(done + it, res)

    # Gaps the interpolation leaves between coarse seam vertices are closed
    # under gravity; a sew stage (gravity off) would let the drape float.
    rf = sim.drape(x, progress=relay, device=device, sewn=True)
    return sim._result(rf.x, cstages + rf.stages)
