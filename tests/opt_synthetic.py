"""Synthetic inputs for the optimizer tests: small structured panels carrying the
SewnMesh field names, garments wrapped around simple shapes, analytic sphere SDF grids
and two-cylinder bodies."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np


def _grid_panel(points_fn, nu, nv, rng, jitter):
    """Vertices points_fn(s, t) on an nu x nv grid of (s, t) in [0,1]^2, interior jittered
    by `jitter` of a cell; triangles CCW with alternating diagonals; perimeter loop."""
    s, t = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    interior = (s > 0) & (s < 1) & (t > 0) & (t < 1)
    s = s + interior * rng.uniform(-jitter, jitter, s.shape) / (nu - 1)
    t = t + interior * rng.uniform(-jitter, jitter, t.shape) / (nv - 1)
    uv = points_fn(s.ravel(), t.ravel())
    vid = np.arange(nu * nv).reshape(nu, nv)
    tris = []
    for i in range(nu - 1):
        for j in range(nv - 1):
            a, b, c, d = vid[i, j], vid[i + 1, j], vid[i + 1, j + 1], vid[i, j + 1]
            if (i + j) % 2 == 0:
                tris += [(a, b, c), (a, c, d)]
            else:
                tris += [(a, b, d), (b, c, d)]
    loop = ([vid[i, 0] for i in range(nu)] + [vid[nu - 1, j] for j in range(1, nv)]
            + [vid[i, nv - 1] for i in range(nu - 2, -1, -1)] + [vid[0, j] for j in range(nv - 2, 0, -1)])
    corners = [vid[0, 0], vid[nu - 1, 0], vid[nu - 1, nv - 1], vid[0, nv - 1]]
    tris = np.array(tris)
    # Keep every triangle counter-clockwise in uv.
    e1, e2 = uv[tris[:, 1]] - uv[tris[:, 0]], uv[tris[:, 2]] - uv[tris[:, 0]]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    if cw.any() and not cw.all():
        raise ValueError("the jitter inverted a triangle")
    if cw.all():
        tris = tris[:, ::-1].copy()
    return uv, tris, np.array(loop), np.array(corners)


def two_panels(seed=0, jitter=0.3, scale=1.0):
    """A rectangle (30 x 24 cm) and an annular sector (curved edges), as a SewnMesh-like
    namespace. scale multiplies the grid resolution."""
    rng = np.random.default_rng(seed)
    panels = []
    rect = lambda s, t: np.stack([30.0 * s, 24.0 * t], 1)

    def sector(s, t):
        r = 20.0 + 14.0 * t
        a = np.deg2rad(-40 + 80 * s)
        return np.stack([50.0 + r * np.sin(a), r * np.cos(a)], 1)

    panels.append(_grid_panel(rect, int(13 * scale), int(11 * scale), rng, jitter))
    panels.append(_grid_panel(sector, int(14 * scale), int(8 * scale), rng, jitter))
    uv, tris, loops, corner_ids, vpanel, tpanel = [], [], [], [], [], []
    off = 0
    for k, (u, t, lp, cn) in enumerate(panels):
        uv.append(u)
        tris.append(t + off)
        loops.append(lp + off)
        corner_ids.append(cn + off)
        vpanel.append(np.full(len(u), k))
        tpanel.append(np.full(len(t), k))
        off += len(u)
    uv = np.concatenate(uv)
    n = len(uv)
    boundary = np.zeros(n, bool)
    for lp in loops:
        boundary[lp] = True
    corner = np.zeros(n, bool)
    corner[np.concatenate(corner_ids)] = True
    x0 = np.zeros((n, 3))
    x0[:, :2] = uv / 100.0
    return SimpleNamespace(
        uv_cm=uv, x0=x0, triangles=np.concatenate(tris).astype(np.int32),
        triangle_panel=np.concatenate(tpanel), vertex_panel=np.concatenate(vpanel),
        boundary=boundary, corner=corner, sewing_pairs=np.zeros((0, 2), np.int64),
        pair_stitch=np.zeros(0, np.int64), panel_names=["rect", "sector"], boundary_loops=loops)


def wrapped_garment(mesh, stretch=1.03, seed=1):
    """A curved 3D garment from the pattern: wrapped on a cylinder of radius 0.2 m with a
    bump, so hinges bend both ways and edges stretch unevenly."""
    rng = np.random.default_rng(seed)
    p = mesh.uv_cm / 100.0
    r = 0.2
    ang = stretch * p[:, 0] / r
    bump = 0.01 * np.sin(2 * np.pi * p[:, 1] / 0.15) * np.cos(2 * np.pi * p[:, 0] / 0.2)
    x = np.stack([(r + bump) * np.sin(ang), -(r + bump) * np.cos(ang), stretch * p[:, 1] + 0.8], 1)
    return x + rng.normal(0, 5e-4, x.shape)


def sphere_sdf(center, radius, lo, hi, h):
    """SDF grid of a sphere (namespace with values (nz, ny, nx) float32, origin, spacing)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    n = np.ceil((hi - lo) / h).astype(int) + 1
    xs = [lo[a] + h * np.arange(n[a]) for a in range(3)]
    z, y, x = np.meshgrid(xs[2], xs[1], xs[0], indexing="ij")
    d = np.sqrt((x - center[0]) ** 2 + (y - center[1]) ** 2 + (z - center[2]) ** 2) - radius
    return SimpleNamespace(values=d.astype(np.float32), origin=lo, spacing=float(h))


def tube(center_xy, radius, z0, z1, n_around=48, n_along=40):
    """A closed tube (open ends) around a vertical axis: (vertices, faces), outward normals."""
    a = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    z = np.linspace(z0, z1, n_along)
    A, Z = np.meshgrid(a, z, indexing="ij")
    v = np.stack([center_xy[0] + radius * np.cos(A), center_xy[1] + radius * np.sin(A), Z], -1).reshape(-1, 3)
    idx = np.arange(n_around * n_along).reshape(n_around, n_along)
    f = []
    for i in range(n_around):
        i2 = (i + 1) % n_around
        for j in range(n_along - 1):
            f += [(idx[i, j], idx[i2, j], idx[i2, j + 1]), (idx[i, j], idx[i2, j + 1], idx[i, j + 1])]
    return v, np.array(f)


def merge(*meshes):
    vs, fs, off = [], [], 0
    for v, f in meshes:
        vs.append(v)
        fs.append(f + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def load_obj(path):
    """Vertices and triangles of an OBJ (polygons fan-triangulated)."""
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                v.append([float(c) for c in line.split()[1:4]])
            elif line.startswith("f "):
                ids = [int(c.split("/")[0]) - 1 for c in line.split()[1:]]
                f += [(ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1)]
    return np.array(v), np.array(f)
