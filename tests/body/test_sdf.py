"""Signed distance fields: values and signs against brute force, gradients,
analytic shapes, open meshes, bounds, caching, files and the `seamfit sdf` command.

Error bound used below. The signed distance d is 1-Lipschitz, and the trilinear
interpolant at p is a convex combination of node values with weights w_n, so
  |I(p) - d(p)| <= sum_n w_n |d(x_n) - d(p)| + e_node <= sum_n w_n |x_n - p| + e_node
              <= sqrt(sum_n w_n |x_n - p|^2) + e_node = h sqrt(sum_a t_a (1 - t_a)) + e_node
(Jensen), at most (sqrt(3)/2) h, where t_a are the fractional cell coordinates
and e_node the error of the node values. Node values are exact point-triangle
distances to a propagated closest triangle, so never below the true distance;
within the exact band they are exact (BAND_TOL), beyond it the propagated
triangle can be slightly off (e_node <= NODE_TOL, checked at nodes).
"""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from seamfit import cli
from seamfit.body import Body, SignedDistanceField, build_sdf, load_body
from seamfit.body import sdf as sdf_mod
from seamfit.errors import BodyError
from seamfit._native import core

from sim_helpers import fresh_sdf_cache  # noqa: F401 (a fixture)
from common import SAMPLES

BODIES = SAMPLES / "bodies"
H = 0.005          # grid spacing for the body tests (the default 2.5 mm is benchmarked)
NODE_TOL = 5e-4    # metres: propagated node values vs exact distances (measured max ~0.25 mm)
BAND_TOL = 1e-6    # metres: nodes within the exact band (|phi| < 1.5 h)


# ----------------------------------------------------------------------------- brute force

def _tri_distance(p, A, B, C):
    """Exact distances from point p to triangles (A, B, C) (arrays of shape (m, 3))."""
    AB, AC, BC = B - A, C - A, C - B
    N = np.cross(AB, AC)
    N /= np.linalg.norm(N, axis=1)[:, None]
    ap = p - A
    h = (ap * N).sum(-1)
    q = ap - h[:, None] * N
    d00, d01, d11 = (AB * AB).sum(1), (AB * AC).sum(1), (AC * AC).sum(1)
    d20, d21 = (q * AB).sum(-1), (q * AC).sum(-1)
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    best = np.where((v >= 0) & (w >= 0) & (v + w <= 1), np.abs(h), np.inf)
    for X, E in ((A, AB), (A, AC), (B, BC)):
        xp = p - X
        t = np.clip((xp * E).sum(-1) / (E * E).sum(1), 0, 1)
        best = np.minimum(best, np.linalg.norm(xp - t[:, None] * E, axis=-1))
    return best


def brute_distance(P, V, F):
    """Exact unsigned distance from each point to the triangle mesh. Exhaustive
    over every triangle that can be closest: the nearest vertex bounds the
    distance, so triangles whose centroid is farther than that plus the largest
    triangle radius cannot win."""
    from scipy.spatial import cKDTree
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cen = (A + B + C) / 3
    rad = np.max([np.linalg.norm(X - cen, axis=1) for X in (A, B, C)])
    dv = cKDTree(V[np.unique(F)]).query(P)[0]
    tree = cKDTree(cen)
    out = np.empty(len(P))
    for q, (p, r) in enumerate(zip(P, dv)):
        cand = np.asarray(tree.query_ball_point(p, r + rad + 1e-9), dtype=np.int64)
        out[q] = _tri_distance(p, A[cand], B[cand], C[cand]).min()
    return out


def brute_winding(P, V, F, chunk=64):
    """Generalized winding number (sum of signed solid angles / 4 pi)."""
    out = np.empty(len(P))
    for s in range(0, len(P), chunk):
        a = V[F[:, 0]][None] - P[s:s + chunk, None]
        b = V[F[:, 1]][None] - P[s:s + chunk, None]
        c = V[F[:, 2]][None] - P[s:s + chunk, None]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        num = (a * np.cross(b, c)).sum(-1)
        den = la * lb * lc + (a * b).sum(-1) * lc + (a * c).sum(-1) * lb + (b * c).sum(-1) * la
        out[s:s + chunk] = 2 * np.arctan2(num, den).sum(axis=1) / (4 * np.pi)
    return out


def node_points(sdf, idx):
    """World positions of node indices idx (n, 3) as (i, j, k)."""
    return sdf.origin + sdf.spacing * idx


def node_values(sdf, idx):
    return sdf.values[idx[:, 2], idx[:, 1], idx[:, 0]].astype(np.float64)


def interp_bound(sdf, P):
    t = (P - sdf.origin) / sdf.spacing
    t = t - np.floor(t)
    return sdf.spacing * np.sqrt((t * (1 - t)).sum(axis=1))


# ----------------------------------------------------------------------------- meshes

def box_mesh(lo, hi, n=4):
    """Closed, outward-oriented box, each face split into n x n quads (2 triangles each)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    verts, faces = [], []
    for axis in range(3):
        for side in (0, 1):
            u, v = [a for a in range(3) if a != axis]
            g = np.linspace(0, 1, n + 1)
            base = len(verts)
            for a in g:
                for b in g:
                    p = np.empty(3)
                    p[axis] = (lo if side == 0 else hi)[axis]
                    p[u] = lo[u] + a * (hi[u] - lo[u])
                    p[v] = lo[v] + b * (hi[v] - lo[v])
                    verts.append(p)
            for i in range(n):
                for j in range(n):
                    q00, q01 = base + i * (n + 1) + j, base + i * (n + 1) + j + 1
                    q10, q11 = q00 + n + 1, q01 + n + 1
                    faces += [[q00, q10, q11], [q00, q11, q01]]
    V = np.array(verts)
    F = np.array(faces)
    # Merge duplicated corner/edge vertices, then orient outward.
    key, inv = np.unique(np.round(V, 12), axis=0, return_inverse=True)
    F = inv.reshape(-1)[F]
    cen = key[F].mean(axis=1)
    nrm = np.cross(key[F[:, 1]] - key[F[:, 0]], key[F[:, 2]] - key[F[:, 0]])
    out = ((cen - 0.5 * (lo + hi)) * nrm).sum(1) < 0
    F[out] = F[out][:, ::-1]
    return key, F.astype(np.int32)


def box_sdf(P, lo, hi):
    c, e = 0.5 * (np.asarray(lo) + hi), 0.5 * (np.asarray(hi) - lo)
    q = np.abs(P - c) - e
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def icosphere(radius, subdiv):
    t = (1 + 5 ** 0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    V /= np.linalg.norm(V, axis=1)[:, None]
    for _ in range(subdiv):
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = V[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        m = inv.reshape(3, -1).T + len(V)
        V = np.vstack([V, mid])
        F = np.concatenate([np.stack([F[:, 0], m[:, 0], m[:, 2]], 1), np.stack([F[:, 1], m[:, 1], m[:, 0]], 1),
                            np.stack([F[:, 2], m[:, 2], m[:, 1]], 1), m])
    return radius * V, F.astype(np.int32)


# ----------------------------------------------------------------------------- fixtures

# Every test builds its fields afresh (sim_helpers.fresh_sdf_cache).
pytestmark = pytest.mark.usefixtures("fresh_sdf_cache")


@pytest.fixture(scope="module")
def body():
    return load_body(BODIES / "women_size06.obj")


@pytest.fixture(scope="module")
def body_sdf(body):
    return build_sdf(body, spacing=H, padding=0.05, cache=False)


def surface_points(body, n, rng, faces=None):
    f = rng.integers(0, body.n_faces, n) if faces is None else rng.choice(faces, n)
    w = rng.dirichlet([1, 1, 1], n)
    return (body.vertices[body.faces[f]] * w[:, :, None]).sum(axis=1), f


# ----------------------------------------------------------------------------- body SDF

def test_grid_layout_covers_body_with_padding(body, body_sdf):
    lo, hi = body_sdf.bounds
    vmin, vmax = body.vertices.min(0), body.vertices.max(0)
    assert np.all(lo <= vmin - 0.05 + 1e-9) and np.all(hi >= vmax + 0.05 - 1e-9)
    assert np.all(lo > vmin - 0.05 - H) and np.all(hi < vmax + 0.05 + H)
    assert body_sdf.values.dtype == np.float32 and body_sdf.values.shape == body_sdf.dims[::-1]
    nx, ny, nz = body_sdf.dims
    assert body_sdf.info["inside_nodes"] == int((body_sdf.values < 0).sum())
    # the body's volume from the inside nodes, vs the mesh volume (52.27 l)
    assert body_sdf.info["inside_nodes"] * H ** 3 * 1000 == pytest.approx(52.27, rel=0.03)


def test_node_values_and_signs_match_brute_force(body, body_sdf):
    rng = np.random.default_rng(1)
    nx, ny, nz = body_sdf.dims
    far = np.stack([rng.integers(0, n, 200) for n in (nx, ny, nz)], axis=1)
    flat = np.flatnonzero(np.abs(body_sdf.values.ravel()) < 0.02)
    pick = rng.choice(flat, 200, replace=False)
    near = np.stack([pick % nx, (pick // nx) % ny, pick // (nx * ny)], axis=1)
    idx = np.concatenate([far, near])
    P = node_points(body_sdf, idx)
    got = node_values(body_sdf, idx)
    exact = brute_distance(P, body.vertices, body.faces)
    err = np.abs(got) - exact
    assert np.max(err) <= NODE_TOL and np.min(err) >= -BAND_TOL  # an upper bound, never below
    assert np.median(np.abs(err)) < 1e-6
    band = exact < 1.5 * H
    assert band.sum() > 50 and np.max(np.abs(err[band])) <= BAND_TOL
    inside = brute_winding(P, body.vertices, body.faces) > 0.5
    assert np.array_equal(got < 0, inside)
    assert inside[:200].sum() > 0 and (~inside[:200]).sum() > 0


def test_sampled_values_within_interpolation_bound(body, body_sdf):
    rng = np.random.default_rng(2)
    S, _ = surface_points(body, 300, rng)
    near = S + rng.normal(scale=0.01, size=S.shape)
    lo, hi = body_sdf.bounds
    far = lo + rng.random((200, 3)) * (hi - lo)
    P = np.concatenate([near, far])
    phi, grad = body_sdf.sample(P)
    exact = brute_distance(P, body.vertices, body.faces)
    signed = np.where(brute_winding(P, body.vertices, body.faces) > 0.5, -exact, exact)
    err = np.abs(phi - signed)
    bound = interp_bound(body_sdf, P) + NODE_TOL
    assert np.all(err <= bound), (err - bound).max()
    assert np.all(bound <= np.sqrt(3) / 2 * H + NODE_TOL)
    # typical errors are far below the worst case
    assert np.median(err) < 0.1 * H
    # where |d| exceeds the bound the sign must be right
    sure = np.abs(signed) > bound
    assert np.array_equal(np.sign(phi[sure]), np.sign(signed[sure]))


def test_gradient_is_exact_gradient_of_interpolant(body_sdf):
    rng = np.random.default_rng(3)
    nx, ny, nz = body_sdf.dims
    cell = np.stack([rng.integers(0, n - 1, 300) for n in (nx, ny, nz)], axis=1)
    frac = 0.1 + 0.8 * rng.random((300, 3))  # away from cell faces
    P = body_sdf.origin + H * (cell + frac)
    phi, grad = body_sdf.sample(P)
    eps = 1e-3 * H
    fd = np.empty_like(grad)
    for a in range(3):
        d = np.zeros(3)
        d[a] = eps
        fd[:, a] = (body_sdf.sample(P + d)[0] - body_sdf.sample(P - d)[0]) / (2 * eps)
    # trilinear is linear along each axis inside a cell: central differences are exact
    np.testing.assert_allclose(grad, fd, rtol=1e-6, atol=1e-6)


def test_gradient_near_surface_is_unit_and_points_away(body, body_sdf):
    rng = np.random.default_rng(4)
    V, F = body.vertices, body.faces
    cen = V[F].mean(axis=1)
    torso = np.flatnonzero((np.abs(cen[:, 0]) < 0.15) & (cen[:, 2] > 0.85) & (cen[:, 2] < 1.35))
    S, f = surface_points(body, 200, rng, faces=torso)
    nrm = np.cross(V[F[f, 1]] - V[F[f, 0]], V[F[f, 2]] - V[F[f, 0]])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    P = S + 0.006 * nrm
    phi, grad = body_sdf.sample(P)
    g = np.linalg.norm(grad, axis=1)
    assert np.all(np.abs(g - 1) < 0.25) and abs(np.median(g) - 1) < 0.05
    cos = (grad * nrm).sum(1) / g
    assert np.median(cos) > 0.98 and np.mean(cos > 0.8) > 0.95


def test_outside_grid_continues_with_distance_to_box(body_sdf):
    lo, hi = body_sdf.bounds
    p_edge = np.array([[0.0, 0.0, hi[2]]])
    p_out = p_edge + [[0.0, 0.0, 0.3]]
    phi_e, _ = body_sdf.sample(p_edge)
    phi_o, g_o = body_sdf.sample(p_out)
    assert phi_o[0] == pytest.approx(phi_e[0] + 0.3, abs=1e-9)
    assert g_o[0, 2] == pytest.approx(1.0)


# ----------------------------------------------------------------------------- analytic shapes

def test_box_mesh_matches_analytic_sdf():
    lo, hi = np.array([-0.2, -0.15, 0.0]), np.array([0.23, 0.17, 1.0])
    V, F = box_mesh(lo, hi, n=5)
    sdf = build_sdf(Body(V, F, name="box"), spacing=0.01, padding=0.1, cache=False)
    nx, ny, nz = sdf.dims
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    P = node_points(sdf, np.stack([i, j, k], -1).reshape(-1, 3))
    exact = box_sdf(P, lo, hi)
    assert np.max(np.abs(sdf.values.reshape(-1) - exact)) < 1e-6  # every node
    rng = np.random.default_rng(5)
    Q = lo - 0.08 + rng.random((2000, 3)) * (hi - lo + 0.16)
    phi, _ = sdf.sample(Q)
    assert np.all(np.abs(phi - box_sdf(Q, lo, hi)) <= interp_bound(sdf, Q) + 1e-6)


def test_sphere_mesh_matches_analytic_sdf():
    R = 0.5
    V, F = icosphere(R, 4)
    sdf = build_sdf(Body(V, F, name="sphere"), spacing=0.01, padding=0.1, cache=False)
    # the mesh is inscribed: it lies between R cos(theta) and R, theta ~ edge / R
    edge = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).max()
    sag = R * (1 - np.cos(edge / R))
    rng = np.random.default_rng(6)
    Q = (rng.random((3000, 3)) - 0.5) * 1.15
    phi, grad = sdf.sample(Q)
    exact = np.linalg.norm(Q, axis=1) - R
    assert np.all(np.abs(phi - exact) <= interp_bound(sdf, Q) + sag + 1e-6)
    assert np.array_equal(phi < 0, np.linalg.norm(Q, axis=1) < R - sag - 0.01) or \
        np.all((phi < 0)[np.linalg.norm(Q, axis=1) < R - sag - 0.01])
    far = np.abs(exact) > 0.05
    radial = Q[far] / np.linalg.norm(Q[far], axis=1)[:, None]
    assert np.all((grad[far] * radial).sum(1) > 0.95)


# ----------------------------------------------------------------------------- open meshes, bounds

def test_open_mesh_sign_from_generalized_winding_number(body, body_sdf):
    rng = np.random.default_rng(7)
    C = body.vertices[body.faces].mean(axis=1)
    # on the crown, the belly and the back (face centroids)
    centres = [C[np.argmax(C[:, 2])], C[np.argmin(np.linalg.norm(C - [0, -0.3, 1.0], axis=1))],
               C[np.argmin(np.linalg.norm(C - [0.05, 0.3, 1.2], axis=1))]]
    remove = np.zeros(body.n_faces, bool)
    for c in centres:
        remove |= np.linalg.norm(C - c, axis=1) < 0.03
    opened = Body(body.vertices, body.faces[~remove], name="open")
    # the closed body's grid (the field's box follows the vertices the faces use, which
    # the holes shrink a little), so that the two fields compare node by node
    lo, hi = body_sdf.bounds
    sdf = build_sdf(opened, spacing=H, bounds=(*lo, *hi), cache=False)
    assert sdf.info["boundary_edges"] > 0 and sdf.info["caps"] == 3
    assert not sdf.info["watertight"]
    assert any("generalized winding" in w for w in sdf.info["warnings"])
    nx, ny, nz = sdf.dims
    flat = np.flatnonzero(np.abs(sdf.values.ravel()) < 0.05)
    pick = rng.choice(flat, 300, replace=False)
    idx = np.stack([pick % nx, (pick // nx) % ny, pick // (nx * ny)], axis=1)
    # nodes near the holes too
    for c in centres:
        ijk = np.round((c - sdf.origin) / H).astype(int)
        idx = np.concatenate([idx, ijk + rng.integers(-8, 9, (40, 3))])
    P = node_points(sdf, idx)
    got = node_values(sdf, idx)
    w = brute_winding(P, opened.vertices, opened.faces)
    clear = np.abs(w - 0.5) > 0.05
    assert clear.sum() > 400
    assert np.array_equal((got < 0)[clear], (w > 0.5)[clear])
    # away from the holes the sign is the closed body's
    assert np.array_equal(sdf.origin, body_sdf.origin) and sdf.dims == body_sdf.dims
    closed = node_values(body_sdf, idx) < 0  # the closed body's sign, checked above
    away = np.min([np.linalg.norm(P - c, axis=1) for c in centres], axis=0) > 0.06
    assert np.array_equal((got < 0)[away], closed[away])


def test_bounds_cutting_the_body(body):
    b = (-0.22, -0.18, 0.72, 0.2, 0.19, 1.31)
    sdf = build_sdf(body, spacing=H, bounds=b, cache=False)
    assert np.allclose(sdf.origin, b[:3])
    lo, hi = sdf.bounds
    assert np.all(hi >= np.array(b[3:]) - 1e-12) and np.all(hi < np.array(b[3:]) + H)
    assert sdf.info["seeded_nodes"] > 0
    rng = np.random.default_rng(8)
    nx, ny, nz = sdf.dims
    idx = np.stack([rng.integers(0, n, 200) for n in (nx, ny, nz)], axis=1)
    idx[:100, 2] = rng.choice([0, nz - 1], 100)  # border nodes: nearest triangles outside the box
    P = node_points(sdf, idx)
    got = node_values(sdf, idx)
    exact = brute_distance(P, body.vertices, body.faces)
    assert np.max(np.abs(np.abs(got) - exact)) <= NODE_TOL
    assert np.array_equal(got < 0, brute_winding(P, body.vertices, body.faces) > 0.5)


def test_build_releases_the_gil(body):
    done = threading.Event()
    result = {}

    def work():
        result["sdf"] = build_sdf(body, spacing=0.008, cache=False)
        done.set()

    th = threading.Thread(target=work)
    t0 = time.perf_counter()
    th.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    assert time.perf_counter() - t0 > 0.05
    assert ticks > 20  # this thread kept running Python code during the build
    assert result["sdf"].info["inside_nodes"] > 0


def test_bad_inputs_raise_body_errors(body):
    with pytest.raises(BodyError, match="spacing"):
        build_sdf(body, spacing=0.0)
    with pytest.raises(BodyError, match="padding"):
        build_sdf(body, spacing=0.01, padding=-1)
    with pytest.raises(BodyError, match="bounds"):
        build_sdf(body, spacing=0.01, bounds=(0, 0, 0, -1, 1, 1))
    with pytest.raises(BodyError, match="max_nodes|spacing"):
        build_sdf(body, spacing=0.0001, cache=False)
    V = body.vertices.copy()
    V[5] = np.nan
    with pytest.raises(BodyError, match="vertex 5"):
        build_sdf(Body(V, body.faces, name="nan"), spacing=0.01)
    with pytest.raises(ValueError, match="entries"):
        core().sdf_sample_points(np.zeros(7, np.float32), (2, 2, 2), (0, 0, 0), 0.1, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="face 0"):
        core().sdf_build(np.zeros((3, 3)), np.array([[0, 1, 3]], np.int32), spacing=0.1)


# ----------------------------------------------------------------------------- cache and files

def small_body(shift=0.0):
    V, F = box_mesh([-0.2, -0.1, 0.0], [0.2, 0.1, 0.8], n=3)
    V = V.copy()
    V[0, 0] += shift
    return Body(V, F, name="smallbox")


def test_cache_hits_and_misses(tmp_path):
    cache = tmp_path / "cache"
    b = small_body()
    first = build_sdf(b, spacing=0.01)
    assert first.source == "built"
    assert len(list((cache / "sdf").glob("*.npz"))) == 1
    again = build_sdf(b, spacing=0.01)
    assert again.source == "memory cache" and np.array_equal(again.values, first.values)
    sdf_mod.clear_memory_cache()
    t0 = time.perf_counter()
    disk = build_sdf(b, spacing=0.01)
    assert disk.source == "disk cache" and time.perf_counter() - t0 < 0.5
    assert np.array_equal(disk.values, first.values) and np.array_equal(disk.origin, first.origin)
    # any change misses
    assert build_sdf(small_body(shift=1e-9), spacing=0.01).source == "built"
    assert build_sdf(b, spacing=0.011).source == "built"
    assert build_sdf(b, spacing=0.01, padding=0.04).source == "built"
    assert build_sdf(b, spacing=0.01, bounds=(-0.3, -0.2, -0.1, 0.3, 0.2, 0.9)).source == "built"
    F2 = b.faces.copy()
    F2[[0, 1]] = F2[[1, 0]]
    assert build_sdf(Body(b.vertices, F2), spacing=0.01).source == "built"
    assert len(list((cache / "sdf").glob("*.npz"))) == 6
    # a corrupt entry is rebuilt and replaced
    sdf_mod.clear_memory_cache()
    entry = cache / "sdf" / f"{sdf_mod.sdf_cache_key(b, 0.01, 0.05)}.npz"
    entry.write_bytes(b"not an npz")
    rebuilt = build_sdf(b, spacing=0.01)
    assert rebuilt.source == "built" and np.array_equal(rebuilt.values, first.values)
    sdf_mod.clear_memory_cache()
    assert build_sdf(b, spacing=0.01).source == "disk cache"
    # cache=False neither reads nor writes
    n = len(list((cache / "sdf").glob("*.npz")))
    assert build_sdf(small_body(shift=2e-9), spacing=0.01, cache=False).source == "built"
    assert len(list((cache / "sdf").glob("*.npz"))) == n
    assert not list((cache / "sdf").glob(".*.tmp"))


def test_save_load_round_trip(tmp_path):
    sdf = build_sdf(small_body(), spacing=0.02, cache=False)
    path = sdf.save(tmp_path / "f.npz")
    back = SignedDistanceField.load(path)
    assert np.array_equal(back.values, sdf.values) and np.array_equal(back.origin, sdf.origin)
    assert back.spacing == sdf.spacing and back.dims == sdf.dims
    assert back.info["cache_key"] == sdf.info["cache_key"]
    P = np.random.default_rng(9).random((50, 3)) - 0.5
    np.testing.assert_array_equal(back.sample(P)[0], sdf.sample(P)[0])
    (tmp_path / "bad.npz").write_bytes(b"garbage")
    with pytest.raises(BodyError, match="bad.npz"):
        SignedDistanceField.load(tmp_path / "bad.npz")
    with pytest.raises(BodyError, match="no such"):
        SignedDistanceField.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(BodyError, match="not a seamfit SDF"):
        SignedDistanceField.load(tmp_path / "other.npz")


# ----------------------------------------------------------------------------- command

def test_sdf_command(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("sdf",))
    body_path = tmp_path / "box.obj"
    from seamfit.body import save_body
    save_body(small_body(), body_path)
    out = tmp_path / "out" / "box_sdf.npz"
    assert cli.main(["sdf", str(body_path), "--out", str(out), "--spacing", "0.02", "--padding", "0.03"]) == 0
    import json
    rep = json.loads(out.with_suffix(".json").read_text())
    sdf = SignedDistanceField.load(out)
    assert rep["dims"] == list(sdf.dims) and rep["spacing"] == 0.02 and rep["watertight"] is True
    assert rep["min_phi"] == pytest.approx(float(sdf.values.min())) and rep["min_phi"] < 0 < rep["max_phi"]
    assert rep["build_seconds"] > 0 and rep["warnings"] == []
    # errors: one line, exit code 2
    capsys.readouterr()
    assert cli.main(["sdf", str(tmp_path / "nope.obj"), "--out", str(out)]) == 2
    assert "no such body file" in capsys.readouterr().err
    assert cli.main(["sdf", str(body_path), "--out", str(tmp_path / "x.txt")]) == 2
    assert ".npz" in capsys.readouterr().err
    assert cli.main(["sdf", str(body_path), "--out", str(out), "--spacing", "-1"]) == 2
    assert "--spacing" in capsys.readouterr().err
    mm = tmp_path / "mm.obj"
    save_body(Body(small_body().vertices * 1000, small_body().faces), mm)
    assert cli.main(["sdf", str(mm), "--out", str(out), "--spacing", "5"]) == 2
    assert "millimetres" in capsys.readouterr().err
