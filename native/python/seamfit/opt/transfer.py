"""Deformation transfer of the base garment onto the target body (paper Eq. 15).

Each garment vertex xbar is expressed relative to a point c on the base body surface
(closest point on a triangle, with barycentric coordinates b) as the offset
o = xbar - c, and carried to the target as

    xtilde = c' + M(c) o,   c' = sum_k b_k v'_k,   M(c) = sum_k b_k M_k,

where M_k is a per-vertex linear map (the area-weighted mean of the deformation
gradients of the incident triangles; a triangle's gradient maps its edge vectors and
its normal scaled by sqrt(2 area) from base to target). Using vertex-interpolated
frames keeps xtilde continuous where the closest point crosses a triangle edge, and
the transfer is exact for identity, rigid and uniformly scaled bodies.

Eq. 15 blends two such transfers, from the closest triangle t0 and the second local
minimum t1 (see native/core/opt/transfer.hpp), by distance difference. As printed,
the weight of t0 is 0.5 + min(d0 - d1, 2B)/(4B) <= 0.5; we use the evidently intended
0.5 + min(d1 - d0, 2B)/(4B): weight 1 when t0 is clearly closest, 1/2 at a tie.
"""
from __future__ import annotations

import time

import numpy as np

from .._native import core
from ..errors import BodyError

DEFAULT_BANDWIDTH = 0.02  # m: blend over distance differences up to 2B = 4 cm


def _body_arrays(body, name: str):
    if hasattr(body, "vertices") and hasattr(body, "faces"):
        v, f = body.vertices, body.faces
    else:
        try:
            v, f = body
        except (TypeError, ValueError):
            raise BodyError(f"{name}: expected a Body (vertices, faces)") from None
    v = np.ascontiguousarray(v, dtype=float)
    f = np.ascontiguousarray(f, dtype=np.int32)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise BodyError(f"{name}: vertices must be (n, 3) and faces (m, 3)")
    return v, f


def _triangle_frames(v, f):
    """Per triangle: the 3x3 matrix [e1, e2, n sqrt(2A)-scaled] and its area."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    e1, e2 = b - a, c - a
    n = np.cross(e1, e2)
    ln = np.linalg.norm(n, axis=1)
    ns = n / np.sqrt(np.maximum(ln, 1e-300))[:, None]
    return np.stack([e1, e2, ns], axis=2), 0.5 * ln


def vertex_deformation(base_v, target_v, faces) -> np.ndarray:
    """M_k (nv, 3, 3): area-weighted mean over incident triangles of F_t = E'_t E_t^-1."""
    eb, area = _triangle_frames(base_v, faces)
    et, _ = _triangle_frames(target_v, faces)
    ok = area > 1e-14 * max(area.max(), 1e-300)
    ft = np.zeros((len(faces), 3, 3))
    ft[ok] = et[ok] @ np.linalg.inv(eb[ok])
    w = np.where(ok, area, 0.0)
    # Vertex-by-triangle incidence weighted by area: one sparse product averages F_t.
    import scipy.sparse as sp

    nf = len(faces)
    inc = sp.csr_matrix((np.repeat(w, 3), (faces.ravel(), np.repeat(np.arange(nf), 3))),
                        shape=(len(base_v), nf))
    wsum = np.asarray(inc.sum(axis=1)).ravel()
    m = (inc @ ft.reshape(nf, 9)).reshape(-1, 3, 3)
    lonely = wsum == 0
    m[~lonely] /= wsum[~lonely, None, None]
    m[lonely] = np.eye(3)
    return m


def _carry(xbar, tri, bary, base_v, target_v, faces, mk):
    fv = faces[tri]                                      # (n, 3) body vertex ids
    c = np.einsum("nk,nkd->nd", bary, base_v[fv])
    c_t = np.einsum("nk,nkd->nd", bary, target_v[fv])
    m = np.einsum("nk,nkij->nij", bary, mk[fv])
    return c_t + np.einsum("nij,nj->ni", m, xbar - c)


def transfer_garment(xbar, base_body, target_body, bandwidth: float = DEFAULT_BANDWIDTH, *,
                     return_info: bool = False):
    """xtilde: the base garment ``xbar`` (N, 3) carried from ``base_body`` to
    ``target_body`` (same topology, e.g. two sizes of one body model).

    With ``return_info`` also returns a dict with the triangles, distances, blend
    weights and the time taken.
    """
    t_start = time.perf_counter()
    bv, bf = _body_arrays(base_body, "base body")
    tv, tf = _body_arrays(target_body, "target body")
    if bv.shape != tv.shape or not np.array_equal(bf, tf):
        raise BodyError(f"base and target bodies must share one topology (base: {len(bv)} vertices, "
                        f"{len(bf)} faces; target: {len(tv)} vertices, {len(tf)} faces, "
                        f"faces {'equal' if np.array_equal(bf, tf) else 'different'})")
    if not bandwidth > 0:
        raise ValueError("bandwidth must be > 0")
    xbar = np.ascontiguousarray(xbar, dtype=float).reshape(-1, 3)
    try:
        hits = core().transfer_query(bv, bf, xbar, float(bandwidth))
    except ValueError as exc:
        raise BodyError(str(exc)) from exc
    mk = vertex_deformation(bv, tv, bf)
    x0 = _carry(xbar, hits["t0"], hits["b0"], bv, tv, bf, mk)
    has1 = hits["t1"] >= 0
    w0 = np.ones(len(xbar))
    # Sound form of Eq. 15: weight 1 on t0 when d1 - d0 >= 2B, 1/2 at a tie.
    gap = np.minimum(hits["d1"][has1] - hits["d0"][has1], 2.0 * bandwidth)
    w0[has1] = 0.5 + gap / (4.0 * bandwidth)
    xt = x0
    if np.any(has1):
        x1 = _carry(xbar[has1], hits["t1"][has1], hits["b1"][has1], bv, tv, bf, mk)
        xt = x0.copy()
        xt[has1] = w0[has1, None] * x0[has1] + (1.0 - w0[has1, None]) * x1
    if not return_info:
        return xt
    info = dict(hits)
    info["w0"] = w0
    info["seconds"] = time.perf_counter() - t_start
    return xt, info
