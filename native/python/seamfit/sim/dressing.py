"""Start positions for dressing: panels placed around the body before the stitches
pull them together.

GarmentCode placements are exact 3D placements (flat panels floating 15-30 cm in
front of / behind the body) and are used as they are. FreeSewing placements are
hints: flat panels standing 25 cm in front of or behind the torso. Those are
wrapped onto a vertical cylinder around the body: every horizontal line of a
panel goes, with its length kept, onto a circle, so the wrap is an isometry of
the flat panel (no initial strain) and the side seams end up at the body's
sides, between torso and arms, instead of being pulled through them.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import SolveError


def sample_sdf(sdf, points: np.ndarray) -> np.ndarray:
    """Trilinear phi of an SDF-like object (values (nz,ny,nx), origin, spacing),
    continued outside the grid like the native sampler (boundary value plus the
    distance to the grid box)."""
    v = np.asarray(sdf.values, dtype=np.float64)
    nz, ny, nx = v.shape
    h = float(sdf.spacing)
    q = (np.asarray(points, float) - np.asarray(sdf.origin, float)) / h
    hi = np.array([nx - 1, ny - 1, nz - 1], float)
    qc = np.clip(q, 0.0, hi)
    outside = np.linalg.norm((q - qc) * h, axis=1)
    b = np.minimum(np.floor(qc).astype(int), (hi - 1).astype(int))
    t = qc - b
    i, j, k = b[:, 0], b[:, 1], b[:, 2]
    tx, ty, tz = t[:, 0], t[:, 1], t[:, 2]
    c = lambda di, dj, dk: v[k + dk, j + dj, i + di]
    c00 = c(0, 0, 0) * (1 - tx) + c(1, 0, 0) * tx
    c10 = c(0, 1, 0) * (1 - tx) + c(1, 1, 0) * tx
    c01 = c(0, 0, 1) * (1 - tx) + c(1, 0, 1) * tx
    c11 = c(0, 1, 1) * (1 - tx) + c(1, 1, 1) * tx
    c0 = c00 * (1 - ty) + c10 * ty
    c1 = c01 * (1 - ty) + c11 * ty
    return c0 * (1 - tz) + c1 * tz + outside


def torso_axis(sdf, z_lo: float, z_hi: float, fallback_y: float = 0.0) -> tuple[float, float]:
    """(x, y) of a vertical axis through the body between heights z_lo..z_hi:
    the centroid of the inside cells within 12 cm of the mid-sagittal plane
    (arms excluded); the body is symmetric about x = 0 in the sewpat frame."""
    zs = np.linspace(z_lo, z_hi, 7)
    xs = np.arange(-0.12, 0.1201, 0.01)
    ys = np.arange(-0.5, 0.5001, 0.01)
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    pts = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
    inside = sample_sdf(sdf, pts) < 0
    if not inside.any():
        return 0.0, fallback_y
    return 0.0, float(pts[inside, 1].mean())


def body_radius(sdf, axis: tuple[float, float], z_lo: float, z_hi: float, *, percentile: float = 85.0,
                r_max: float = 0.6, n_angles: int = 72, dz: float = 0.01, dr: float = 0.0025) -> float:
    """Radius about `axis` that clears the body between z_lo and z_hi.

    Along each horizontal ray from the axis the body's outer boundary is taken
    at the first exit after the first entry: through the torso (not on into an
    arm beyond it), or through one leg where the axis runs between the legs. Per
    height the `percentile` over ray directions drops the few rays that run
    into an arm where it joins the shoulder; the maximum over heights is returned.
    """
    zs = np.arange(z_lo, z_hi + 0.5 * dz, dz) if z_hi > z_lo else np.array([z_lo])
    th = np.linspace(0.0, 2 * np.pi, n_angles, endpoint=False)
    rs = np.arange(0.0, r_max + 0.5 * dr, dr)
    Z, T, R = np.meshgrid(zs, th, rs, indexing="ij")
    pts = np.c_[axis[0] + R.ravel() * np.cos(T.ravel()), axis[1] + R.ravel() * np.sin(T.ravel()), Z.ravel()]
    inside = (sample_sdf(sdf, pts) < 0).reshape(Z.shape)
    radius = np.zeros(Z.shape[:2])
    for a in range(Z.shape[0]):
        for b in range(Z.shape[1]):
            row = inside[a, b]
            if not row.any():
                continue
            first_in = int(np.argmax(row))
            out = np.flatnonzero(~row[first_in:])
            radius[a, b] = rs[first_in + out[0]] if len(out) else rs[-1]
    per_height = np.percentile(radius, percentile, axis=1)
    return float(per_height.max())


def wrap_on_cylinder(x: np.ndarray, vertices: np.ndarray, axis: tuple[float, float], radius: float,
                     back: bool) -> np.ndarray:
    """Wrap the flat vertical panel made of `vertices` onto the cylinder.

    The panel's horizontal coordinate is the world x (sewpat hints stand in
    planes of constant y, x = 0 on the centre front/back line), so the point at
    x goes to angle x / radius measured from the front (-y) or the back (+y).
    Heights are kept.
    """
    out = x.copy()
    u = x[vertices, 0] - axis[0]
    ang = u / radius
    out[vertices, 0] = axis[0] + radius * np.sin(ang)
    side = 1.0 if back else -1.0
    out[vertices, 1] = axis[1] + side * radius * np.cos(ang)
    return out


def initial_positions(mesh, pattern=None, sdf=None, mode: str = "auto", margin: float = 0.02) -> tuple[np.ndarray, dict]:
    """Start positions for `Simulator.drape`, and a dict describing what was done.

    mode: "auto" wraps the panels whose placement is a hint (FreeSewing) and
    keeps exact ones (GarmentCode); "wrap" wraps every panel; "none" keeps the
    mesh's x0. Wrapping needs `pattern` (placement kinds and sides) and `sdf`.
    """
    x0 = np.asarray(mesh.x0, dtype=np.float64).copy()
    info = {"mode": mode, "wrapped_panels": []}
    if mode not in ("auto", "wrap", "none"):
        raise SolveError(f"unknown dressing mode {mode!r} (auto, wrap or none)")
    if mode == "none" or pattern is None:
        return x0, info
    names = list(getattr(mesh, "panel_names", []) or [])
    vpanel = np.asarray(getattr(mesh, "vertex_panel", []))
    if not names or len(vpanel) != len(x0):
        raise SolveError("dressing needs the mesh's panel_names and vertex_panel")
    wrap = []
    for k, name in enumerate(names):
        pl = pattern.panel(name).placement
        if mode == "wrap" or pl.kind == "hint":
            wrap.append((k, name, pl))
    if not wrap:
        return x0, info
    if sdf is None:
        raise SolveError("wrapping hint placements onto the body needs the body's SDF")
    sel = np.isin(vpanel, [k for k, _, _ in wrap])
    z_lo, z_hi = float(x0[sel, 2].min()), float(x0[sel, 2].max())
    plane_y = [float(np.median(x0[vpanel == k, 1])) for k, _, _ in wrap]
    axis = torso_axis(sdf, z_lo, z_hi, fallback_y=float(np.mean(plane_y)))
    radius = body_radius(sdf, axis, z_lo, z_hi) + margin
    for (k, name, pl), py in zip(wrap, plane_y):
        side = (pl.side or "").lower()
        back = True if "back" in side else False if "front" in side else py > axis[1]
        x0 = wrap_on_cylinder(x0, np.flatnonzero(vpanel == k), axis, radius, back)
        info["wrapped_panels"].append(name)
    info.update(axis=[float(a) for a in axis], radius=float(radius), z_range=[z_lo, z_hi])
    if not math.isfinite(radius) or radius <= 0:
        raise SolveError("could not find a wrapping radius around the body")
    return x0, info
