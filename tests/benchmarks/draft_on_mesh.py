"""The drafted pattern on the base pattern's mesh: each boundary vertex moved to the same
fraction of arc length along the same edge of the draft's panel, so a fixed mesh can be
draped with the draft's shape (the objective-alignment and accuracy benchmarks)."""
from __future__ import annotations

import numpy as np


def _arc(outline: np.ndarray) -> np.ndarray:
    """Cumulative arc length at each outline point of a closed polyline, and the total."""
    seg = np.linalg.norm(np.diff(np.vstack([outline, outline[:1]]), axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(seg)])


def _point_at(outline: np.ndarray, s_all: np.ndarray, s: float) -> np.ndarray:
    total = s_all[-1]
    s = s % total
    i = int(np.searchsorted(s_all, s, side="right") - 1)
    i = min(i, len(outline) - 1)
    a, b = outline[i], outline[(i + 1) % len(outline)]
    seg = s_all[i + 1] - s_all[i]
    t = 0.0 if seg <= 0 else (s - s_all[i]) / seg
    return a + t * (b - a)


def _edge_ranges(panel, s_all) -> list[tuple[float, float]]:
    total = s_all[-1]
    out = []
    for e in panel.edges:
        s0, s1 = s_all[e.start], s_all[e.end] if e.end != 0 else total
        if s1 <= s0:
            s1 += total
        out.append((s0, s1))
    return out


def _project(outline, s_all, pts):
    """Arc position of each point on the closed polyline (nearest segment)."""
    a = outline
    b = np.roll(outline, -1, axis=0)
    d = b - a
    dd = np.maximum(np.sum(d * d, axis=1), 1e-300)
    out = np.empty(len(pts))
    for k, p in enumerate(pts):
        t = np.clip(np.sum((p - a) * d, axis=1) / dd, 0.0, 1.0)
        q = a + t[:, None] * d
        i = int(np.argmin(np.sum((q - p) ** 2, axis=1)))
        out[k] = s_all[i] + t[i] * np.sqrt(dd[i])
    return out


def truth_on_mesh(mesh, param, base, truth) -> np.ndarray:
    """theta (n_theta, 2) m: each boundary vertex of the base mesh moved to the same
    fraction of arc length along the same edge of the truth's panel, the panel then rigidly
    aligned onto the base one. Raises ValueError where the panels' edges differ."""
    uv = np.asarray(mesh.uv_cm, dtype=float)
    vp = np.asarray(mesh.vertex_panel)
    theta = np.zeros((param.n_theta, 2))
    for k, name in enumerate(mesh.panel_names):
        bp, tp = base.panel(name), truth.panel(name)
        if len(bp.edges) != len(tp.edges):
            raise ValueError(f"panel {name}: {len(bp.edges)} edges in the base, {len(tp.edges)} in the truth")
        ids = param.boundary_ids[vp[param.boundary_ids] == k]
        sb, st_ = _arc(bp.outline_cm), _arc(tp.outline_cm)
        rb, rt = _edge_ranges(bp, sb), _edge_ranges(tp, st_)
        s = _project(bp.outline_cm, sb, uv[ids])
        new = np.zeros((len(ids), 2))
        for j, sj in enumerate(s):
            for (a0, a1), (t0, t1) in zip(rb, rt):
                x = sj if sj >= a0 else sj + sb[-1]
                if a0 <= x <= a1:
                    f = (x - a0) / max(a1 - a0, 1e-12)
                    new[j] = _point_at(tp.outline_cm, st_, t0 + f * (t1 - t0))
                    break
        # rigid alignment onto the base panel (R^fix is not invariant to where a panel lies)
        A, B = uv[ids], new
        ca, cb = A.mean(axis=0), B.mean(axis=0)
        U, _, Vt = np.linalg.svd((B - cb).T @ (A - ca))
        R = (U @ Vt).T
        if np.linalg.det(R) < 0:
            Vt[-1] *= -1
            R = (U @ Vt).T
        theta[param.theta_index[ids]] = 0.01 * ((B - cb) @ R.T + ca)
    return theta
