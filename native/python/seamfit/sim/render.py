"""A simple orthographic picture of a drape: front, side and back views of the
garment (flat-shaded, one colour per panel) over the body, drawn with matplotlib
polygons sorted back to front (painter's algorithm). Enough for a README or a
report; not a renderer."""
from __future__ import annotations

from pathlib import Path

import numpy as np

_PANEL_COLOURS = np.array([
    [0.85, 0.33, 0.31], [0.30, 0.55, 0.80], [0.40, 0.70, 0.40], [0.90, 0.65, 0.25],
    [0.60, 0.45, 0.75], [0.35, 0.75, 0.75], [0.80, 0.50, 0.65], [0.65, 0.60, 0.40],
])

# Views: (name, horizontal axis, depth axis toward the viewer); Z is up, the body faces -Y.
_VIEWS = (("front", np.array([1.0, 0, 0]), np.array([0, -1.0, 0])),
          ("side", np.array([0, -1.0, 0]), np.array([-1.0, 0, 0])),
          ("back", np.array([-1.0, 0, 0]), np.array([0, 1.0, 0])))


def _shade(tri_pts: np.ndarray, toward: np.ndarray, base: np.ndarray) -> np.ndarray:
    n = np.cross(tri_pts[:, 1] - tri_pts[:, 0], tri_pts[:, 2] - tri_pts[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    light = toward + np.array([0.3, 0.2, 0.6])
    light /= np.linalg.norm(light)
    lam = np.abs(n @ light)  # two-sided cloth
    return np.clip(base * (0.35 + 0.65 * lam[:, None]), 0, 1)


def render_drape(path, x: np.ndarray, triangles: np.ndarray, triangle_panel: np.ndarray | None = None,
                 body_vertices: np.ndarray | None = None, body_faces: np.ndarray | None = None,
                 title: str | None = None, dpi: int = 110) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    x = np.asarray(x, float)
    tris = np.asarray(triangles, int)
    panel = np.zeros(len(tris), int) if triangle_panel is None else np.asarray(triangle_panel, int)
    cloth_col = _PANEL_COLOURS[panel % len(_PANEL_COLOURS)]
    lo, hi = x.min(axis=0), x.max(axis=0)
    if body_vertices is not None:
        bv = np.asarray(body_vertices, float)
        bf = np.asarray(body_faces, int)
        # Only the part of the body near the garment, so the picture is not mostly legs.
        zlo, zhi = lo[2] - 0.15, hi[2] + 0.15
        keep = np.all((bv[bf][:, :, 2] > zlo) & (bv[bf][:, :, 2] < zhi), axis=1)
        bf = bf[keep]
    fig, axes = plt.subplots(1, 3, figsize=(11, 5.2))
    for ax, (name, right, toward) in zip(axes, _VIEWS):
        polys, cols, depth = [], [], []
        pts = x[tris]
        polys.append(np.stack([pts @ right, pts[:, :, 2]], axis=-1))
        cols.append(_shade(pts, toward, cloth_col))
        depth.append((pts @ toward).mean(axis=1))
        if body_vertices is not None and len(bf):
            bp = bv[bf]
            polys.append(np.stack([bp @ right, bp[:, :, 2]], axis=-1))
            cols.append(_shade(bp, toward, np.tile([0.82, 0.80, 0.78], (len(bf), 1))))
            # Cloth lies within millimetres of the skin: bias the body back so
            # centroid sorting never draws skin over the cloth resting on it.
            depth.append((bp @ toward).mean(axis=1) - 0.03)
        P = np.concatenate(polys)
        C = np.concatenate(cols)
        order = np.argsort(np.concatenate(depth))  # far first
        ax.add_collection(PolyCollection(P[order], facecolors=C[order], edgecolors="none", antialiased=False))
        h = np.r_[P[..., 0].ravel()]
        v = np.r_[P[..., 1].ravel()]
        cx, cz = 0.5 * (h.min() + h.max()), 0.5 * (v.min() + v.max())
        half = 0.55 * max(h.max() - h.min(), v.max() - v.min())
        ax.set_xlim(cx - half, cx + half)
        ax.set_ylim(cz - half, cz + half)
        ax.set_aspect("equal")
        ax.set_title(name)
        ax.axis("off")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
