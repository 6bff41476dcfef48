"""Synthetic inputs for the simulator tests: structured triangulated panels with
the SewnMesh field names, sewn into tubes, and analytic SDF grids built in numpy."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest


def grid_panel(width_cm: float, height_cm: float, nu: int, nv: int, jitter: float = 0.0, seed: int = 0):
    """Rectangle [0,w] x [0,h] (cm) as (nu+1)(nv+1) vertices, alternating diagonals."""
    u = np.linspace(0.0, width_cm, nu + 1)
    v = np.linspace(0.0, height_cm, nv + 1)
    uu, vv = np.meshgrid(u, v)
    uv = np.c_[uu.ravel(), vv.ravel()]
    if jitter > 0:
        rng = np.random.default_rng(seed)
        inner = np.ones((nv + 1, nu + 1), bool)
        inner[0, :] = inner[-1, :] = inner[:, 0] = inner[:, -1] = False
        step = min(width_cm / nu, height_cm / nv)
        uv[inner.ravel()] += jitter * step * rng.uniform(-1, 1, (inner.sum(), 2))
    tris = []
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b, c, d = a + 1, a + nu + 1, a + nu + 2
            if (i + j) % 2 == 0:
                tris += [[a, b, d], [a, d, c]]
            else:
                tris += [[a, b, c], [b, d, c]]
    return uv, np.array(tris, dtype=np.int32)


def equilateral_sheet(width_m=0.2, n=16):
    """Near-equilateral triangulation of a width x (sqrt(3)/2 width) sheet (pattern in cm)."""
    a = width_m / n
    h = a * np.sqrt(3) / 2
    idx = {}
    pts = []
    for j in range(n + 1):
        for i in range(n + 1):
            idx[i, j] = len(pts)
            pts.append([i * a + (0.5 * a if j % 2 else 0.0), j * h])
    tris = []
    for j in range(n):
        for i in range(n):
            if j % 2 == 0:
                tris += [[idx[i, j], idx[i + 1, j], idx[i, j + 1]], [idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]]]
            else:
                tris += [[idx[i, j], idx[i + 1, j + 1], idx[i, j + 1]], [idx[i, j], idx[i + 1, j], idx[i + 1, j + 1]]]
    p = np.array(pts)
    return SimpleNamespace(uv_cm=100.0 * p, x0=np.c_[p, np.zeros(len(p))], triangles=np.array(tris, np.int32),
                           sewing_pairs=np.zeros((0, 2), np.int32))


def sewn_tube(radius_m=0.12, height_cm=30.0, nu=10, nv=8, gap_m=0.05, z0=0.0, jitter=0.0, seed=0,
              ease=1.15):
    """Two flat panels (front/back), each half a tube of circumference
    ease * 2 pi radius, standing `gap_m` beyond the radius in front of and behind
    the z axis, sewn along both vertical sides."""
    width_cm = 100.0 * ease * np.pi * radius_m
    uv1, t1 = grid_panel(width_cm, height_cm, nu, nv, jitter, seed)
    uv2, t2 = grid_panel(width_cm, height_cm, nu, nv, jitter, seed + 1)
    n1 = len(uv1)
    uv = np.vstack([uv1, uv2])
    # Front panel faces -y (outward normal -y); back panel faces +y.
    tris = np.vstack([t1[:, [0, 2, 1]], t2 + n1]).astype(np.int32)
    d = radius_m + gap_m
    x_front = np.c_[0.01 * uv1[:, 0] - 0.005 * width_cm, np.full(n1, -d), z0 + 0.01 * uv1[:, 1]]
    x_back = np.c_[0.01 * uv2[:, 0] - 0.005 * width_cm, np.full(n1, d), z0 + 0.01 * uv2[:, 1]]
    x0 = np.vstack([x_front, x_back])
    rows = np.arange(nv + 1)
    left = rows * (nu + 1)
    right = rows * (nu + 1) + nu
    pairs = np.vstack([np.c_[left, n1 + left], np.c_[right, n1 + right]]).astype(np.int32)
    vp = np.r_[np.zeros(n1, int), np.ones(n1, int)]
    return SimpleNamespace(uv_cm=uv, x0=x0, triangles=tris, sewing_pairs=pairs,
                           vertex_panel=vp, triangle_panel=vp[tris[:, 0]], panel_names=["front", "back"])


def flat_sheet(width_cm=20.0, height_cm=20.0, nu=6, nv=6, jitter=0.0, seed=0):
    uv, tris = grid_panel(width_cm, height_cm, nu, nv, jitter, seed)
    x0 = np.c_[0.01 * uv, np.zeros(len(uv))]
    return SimpleNamespace(uv_cm=uv, x0=x0, triangles=tris, sewing_pairs=np.zeros((0, 2), np.int32))


def sdf_grid(fn, lo, hi, spacing):
    """Sample fn(points (M,3)) -> phi on a grid; values shaped (nz, ny, nx)."""
    lo = np.asarray(lo, float)
    n = np.ceil((np.asarray(hi, float) - lo) / spacing).astype(int) + 1
    xs = lo[0] + spacing * np.arange(n[0])
    ys = lo[1] + spacing * np.arange(n[1])
    zs = lo[2] + spacing * np.arange(n[2])
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
    pts = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
    values = fn(pts).reshape(Z.shape).astype(np.float32)
    return SimpleNamespace(values=values, origin=lo, spacing=float(spacing))


def capsule_sdf(radius=0.12, z_lo=-0.2, z_hi=0.6, spacing=0.01, pad=0.15):
    """Vertical capsule around the z axis from z_lo to z_hi."""
    def fn(p):
        z = np.clip(p[:, 2], z_lo, z_hi)
        d = p - np.c_[np.zeros(len(p)), np.zeros(len(p)), z]
        return np.linalg.norm(d, axis=1) - radius
    r = radius + pad
    return sdf_grid(fn, (-r, -r, z_lo - r), (r, r, z_hi + r), spacing)


def sphere_sdf(center=(0, 0, 0), radius=0.1, spacing=0.01, pad=0.1):
    c = np.asarray(center, float)
    r = radius + pad
    return sdf_grid(lambda p: np.linalg.norm(p - c, axis=1) - radius, c - r, c + r, spacing)


def floor_sdf(z=0.0, size=1.0, spacing=0.05):
    return sdf_grid(lambda p: p[:, 2] - z, (-size, -size, z - size), (size, size, z + size), spacing)


def revolution_sdf(z_profile, r_profile, spacing=0.01, pad=0.1):
    """Closed solid of revolution about the z axis with radius r(z) (piecewise
    linear through the given samples, closed by flat caps): exact signed distance
    computed in the (r, z) half-plane."""
    z_profile = np.asarray(z_profile, float)
    r_profile = np.asarray(r_profile, float)
    # Profile polygon in (r, z): axis -> bottom cap -> side -> top cap -> axis.
    poly = np.vstack([[0.0, z_profile[0]], np.c_[r_profile, z_profile], [0.0, z_profile[-1]]])

    def exact(q):
        best = np.full(len(q), np.inf)
        a, b = poly[:-1], poly[1:]
        for k in range(len(a)):
            ab = b[k] - a[k]
            t = np.clip(((q - a[k]) @ ab) / max(ab @ ab, 1e-30), 0, 1)
            best = np.minimum(best, np.linalg.norm(q - (a[k] + t[:, None] * ab), axis=1))
        zq = q[:, 1]
        rin = np.interp(zq, z_profile, r_profile)
        inside = (zq >= z_profile[0]) & (zq <= z_profile[-1]) & (q[:, 0] < rin)
        return np.where(inside, -best, best)

    def fn(p):
        # The field depends on (r, z) only: tabulate it finely in 2D, then interpolate.
        from scipy.ndimage import map_coordinates
        r = np.hypot(p[:, 0], p[:, 1])
        h = spacing / 4
        r_ax = np.arange(0.0, r.max() + 2 * h, h)
        z_ax = np.arange(p[:, 2].min() - h, p[:, 2].max() + 2 * h, h)
        R, Z = np.meshgrid(r_ax, z_ax, indexing="ij")
        table = exact(np.c_[R.ravel(), Z.ravel()]).reshape(R.shape)
        return map_coordinates(table, [r / h, (p[:, 2] - z_ax[0]) / h], order=1)

    rmax = r_profile.max() + pad
    return sdf_grid(fn, (-rmax, -rmax, z_profile[0] - pad), (rmax, rmax, z_profile[-1] + pad), spacing)


def hourglass_sdf(spacing=0.01):
    """A torso-like solid: waist r = 0.11 m at z = 0.45, hips r = 0.15 m at
    z = 0.1, flaring to 0.25 m at the bottom (z = -0.3) so nothing slides off."""
    z = np.linspace(-0.3, 0.7, 41)
    r = 0.13 + 0.02 * np.cos(np.pi * (z - 0.1) / 0.35)
    r = np.where(z < 0.1, 0.15 + 0.25 * (0.1 - z) ** 2 / 0.16, np.where(z > 0.45, 0.11, r))
    return revolution_sdf(z, r, spacing=spacing, pad=0.12)


@pytest.fixture
def fresh_sdf_cache(tmp_path, monkeypatch):
    """SDFs built afresh: a private disk cache and an empty memory cache around the test."""
    from seamfit.body import sdf as sdf_mod

    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    sdf_mod.clear_memory_cache()
    yield
    sdf_mod.clear_memory_cache()
