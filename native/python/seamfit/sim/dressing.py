"""Start positions for dressing: panels placed around the body before the stitches
pull them together.

GarmentCode placements are exact 3D placements (flat panels floating 15-30 cm in
front of / behind the body) and are used as they are. FreeSewing placements are
hints: flat panels standing 25 cm in front of or behind the torso. Those are
wrapped onto a vertical cylinder around the body: every horizontal line of a
panel goes, with its length kept, onto a circle, so the wrap is an isometry of
the flat panel (no initial strain) and the side seams end up at the body's
sides, between torso and arms, instead of being pulled through them.

Panels drafted as annular sectors (circle skirts: the waist is a circular arc)
go onto the cone they describe instead: polar coordinates about the arc's
centre become slant distance and azimuth, the sectors of all such panels
together close the cone once around the body, and the waist arc lands as a
horizontal circle at the anchor's (waist) height. Also an isometry.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import SolveError
from ..pattern.sectors import fit_circle


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


def _waist_arc(mesh, k: int, anchor: int | None):
    """The run of panel k's outline through the anchor vertex, between the
    nearest pattern corners on either side (the waist curve for a hint panel)."""
    loop = np.asarray(mesh.boundary_loops[k])
    if anchor is None or anchor not in set(loop.tolist()):
        return None
    corner = np.asarray(getattr(mesh, "corner", np.zeros(mesh.n_vertices, bool)))
    i0 = int(np.flatnonzero(loop == anchor)[0])
    n = len(loop)
    run = [loop[i0]]
    for step in (1, -1):
        i = i0
        for _ in range(n - 1):
            i = (i + step) % n
            run.append(loop[i]) if step == 1 else run.insert(0, loop[i])
            if corner[loop[i]]:
                break
    return np.array(run)


def cone_sector(mesh, k: int, anchor: int | None, min_angle: float = 0.6):
    """(centre, waist radius, angular extent) when panel k is an annular
    sector about the centre of its waist arc, else None."""
    run = _waist_arc(mesh, k, anchor)
    if run is None or len(run) < 5:
        return None
    uv = 0.01 * np.asarray(mesh.uv_cm)[run]
    c, r, rms = fit_circle(uv)
    if not math.isfinite(r) or rms > 0.02 * r:
        return None
    ang = np.unwrap(np.arctan2(uv[:, 1] - c[1], uv[:, 0] - c[0]))
    if ang.max() - ang.min() < min_angle:
        return None  # a gentle curve: the cylinder is the better fit
    pts = 0.01 * np.asarray(mesh.uv_cm)[np.asarray(mesh.vertex_panel) == k]
    a = np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0])
    # angular extent of the whole panel about the centre (smallest covering arc)
    srt = np.sort(a)
    gaps = np.diff(np.r_[srt, srt[0] + 2 * np.pi])
    extent = 2 * np.pi - gaps.max()
    return c, r, extent


def wrap_on_cone(x: np.ndarray, uv_m: np.ndarray, vertices: np.ndarray, centre: np.ndarray, axis, apex_z: float,
                 sin_beta: float, azimuth_mid: float, theta_mid: float, scale: float, mirror: bool) -> np.ndarray:
    """Put the pattern points about `centre` on the cone with apex above the
    axis: slant distance = pattern radius, azimuth = azimuth_mid + scale * (theta - theta_mid)."""
    out = x.copy()
    d = uv_m[vertices] - centre
    r = np.linalg.norm(d, axis=1)
    th = np.arctan2(d[:, 1], d[:, 0])
    th = theta_mid + np.angle(np.exp(1j * (th - theta_mid)))
    az = azimuth_mid + (-1 if mirror else 1) * scale * (th - theta_mid)
    cos_beta = math.sqrt(max(1.0 - sin_beta ** 2, 0.0))
    out[vertices, 0] = axis[0] + r * sin_beta * np.sin(az)
    out[vertices, 1] = axis[1] - r * sin_beta * np.cos(az)
    out[vertices, 2] = apex_z - r * cos_beta
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
    uv_m = 0.01 * np.asarray(mesh.uv_cm, dtype=np.float64)
    landmark = getattr(mesh, "landmark_vertex", {}) or {}
    cones = {}
    for k, name, pl in wrap:
        anchor = landmark.get((name, (pl.extra or {}).get("anchor_landmark")))
        sec = cone_sector(mesh, k, anchor)
        if sec is not None:
            cones[k] = (sec, anchor)
    total = sum(sec[2] for sec, _ in cones.values())
    if cones:
        sin_beta = min(total / (2 * np.pi), 1.0)
        # the waist circle at the anchors' mean height (the body's waist)
        z_waist = float(np.mean([x0[a, 2] for _, a in cones.values()]))
        r_waist = float(np.mean([sec[1] for sec, _ in cones.values()]))
        apex_z = z_waist + r_waist * math.sqrt(max(1 - sin_beta ** 2, 0.0))
        info["cone"] = {"panels": [names[k] for k in cones], "half_angle_deg": math.degrees(math.asin(sin_beta)),
                        "apex_z": apex_z}
        # consecutive azimuth ranges, front panels centred on the front
        az0 = 0.0
        for k, ((c, r, extent), anchor) in cones.items():
            sel = np.flatnonzero(vpanel == k)
            pl = pattern.panel(names[k]).placement
            side = (pl.side or "").lower()
            front = "back" not in side
            span = 2 * np.pi * extent / total
            mid = 0.0 if (front and len(cones) == 1) else az0 + 0.5 * span
            if len(cones) > 1:
                az0 += span
            a_anchor = math.atan2(uv_m[anchor, 1] - c[1], uv_m[anchor, 0] - c[0])
            # +u goes towards +x (the body's left) for front panels, -x for back ones
            R = np.asarray(pl.rotation, float)
            mirror = (R[0, 0] < 0) != (not front)
            x0 = wrap_on_cone(x0, uv_m, sel, c, axis, apex_z, sin_beta, mid if front else mid + np.pi,
                              a_anchor, 2 * np.pi / total, mirror)
            info["wrapped_panels"].append(names[k])
    for (k, name, pl), py in zip(wrap, plane_y):
        if k in cones:
            continue
        side = (pl.side or "").lower()
        back = True if "back" in side else False if "front" in side else py > axis[1]
        x0 = wrap_on_cylinder(x0, np.flatnonzero(vpanel == k), axis, radius, back)
        info["wrapped_panels"].append(name)
    info.update(axis=[float(a) for a in axis], radius=float(radius), z_range=[z_lo, z_hi])
    if not math.isfinite(radius) or radius <= 0:
        raise SolveError("could not find a wrapping radius around the body")
    return x0, info
