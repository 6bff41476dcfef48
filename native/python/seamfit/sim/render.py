"""A simple orthographic picture of a drape: front, side and back views of the
garment (flat-shaded, one colour per panel) over the body, triangles sorted back to
front (painter's algorithm) and handed to matplotlib's Agg rasterizer in one call.
Enough for a README or a report; not a renderer."""
from __future__ import annotations

import functools
import io
from pathlib import Path

import numpy as np

from ..fileio import atomic_write_bytes

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


def _flat_triangles(verts: np.ndarray, colours: np.ndarray):
    """An artist that fills triangles (N, 3, 2 in data coordinates), each with one RGB
    colour, in the given order. Agg draws them all in one C call (its Gouraud triangles
    with the three corners alike); a PolyCollection made a Path object per triangle and
    drew them one by one, which took most of a 60K-triangle picture's time."""
    rgba = np.concatenate([np.asarray(colours, float), np.ones((len(colours), 1))], axis=1)
    return _flat_triangles_class()(np.ascontiguousarray(verts, dtype=float),
                                   np.ascontiguousarray(np.repeat(rgba[:, None, :], 3, axis=1)))


@functools.cache
def _flat_triangles_class():
    from matplotlib.artist import Artist

    class FlatTriangles(Artist):
        def __init__(self, verts, colours):
            super().__init__()
            self._verts, self._colours = verts, colours

        def draw(self, renderer):
            if not self.get_visible() or not len(self._verts):
                return
            gc = renderer.new_gc()
            self._set_gc_clip(gc)
            renderer.draw_gouraud_triangles(gc, self._verts, self._colours, self.axes.transData.frozen())
            gc.restore()

    return FlatTriangles


def _draw_view(ax, x, tris, panel, bv, bf, right, toward):
    cloth_col = _PANEL_COLOURS[panel % len(_PANEL_COLOURS)]
    pts = x[tris]
    polys = [np.stack([pts @ right, pts[:, :, 2]], axis=-1)]
    cols = [_shade(pts, toward, cloth_col)]
    depth = [(pts @ toward).mean(axis=1)]
    if bv is not None and len(bf):
        bp = bv[bf]
        polys.append(np.stack([bp @ right, bp[:, :, 2]], axis=-1))
        cols.append(_shade(bp, toward, np.tile([0.82, 0.80, 0.78], (len(bf), 1))))
        # Cloth lies within millimetres of the skin: bias the body back so
        # centroid sorting never draws skin over the cloth resting on it.
        depth.append((bp @ toward).mean(axis=1) - 0.03)
    P = np.concatenate(polys)
    C = np.concatenate(cols)
    order = np.argsort(np.concatenate(depth))  # far first
    ax.add_artist(_flat_triangles(P[order], C[order]))   # the limits are set just below
    h, v = P[..., 0].ravel(), P[..., 1].ravel()
    cx, cz = 0.5 * (h.min() + h.max()), 0.5 * (v.min() + v.max())
    half = 0.55 * max(h.max() - h.min(), v.max() - v.min())
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cz - half, cz + half)
    ax.set_aspect("equal")
    ax.axis("off")


def _body_near(x, body_vertices, body_faces, margin=0.15):
    if body_vertices is None:
        return None, None
    bv = np.asarray(body_vertices, float)
    bf = np.asarray(body_faces, int)
    zlo, zhi = x[:, 2].min() - margin, x[:, 2].max() + margin
    keep = np.all((bv[bf][:, :, 2] > zlo) & (bv[bf][:, :, 2] < zhi), axis=1)
    return bv, bf[keep]


def render_front_grid(path, items, columns: int = 3, dpi: int = 90) -> Path:
    """Front views of several drapes: items = [(title, x, triangles, triangle_panel,
    body_vertices, body_faces), ...]."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = (len(items) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(3.4 * columns, 3.6 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (title, x, tris, panel, bv, bf) in zip(axes.ravel(), items):
        x = np.asarray(x, float)
        bv, bf = _body_near(x, bv, bf)
        _draw_view(ax, x, np.asarray(tris, int), np.asarray(panel, int), bv, bf, *_VIEWS[0][1:])
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return atomic_write_bytes(Path(path), buf.getvalue())


def render_drape(path, x: np.ndarray, triangles: np.ndarray, triangle_panel: np.ndarray | None = None,
                 body_vertices: np.ndarray | None = None, body_faces: np.ndarray | None = None,
                 title: str | None = None, dpi: int = 110) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x = np.asarray(x, float)
    tris = np.asarray(triangles, int)
    panel = np.zeros(len(tris), int) if triangle_panel is None else np.asarray(triangle_panel, int)
    bv, bf = _body_near(x, body_vertices, body_faces)
    fig, axes = plt.subplots(1, 3, figsize=(11, 5.2))
    for ax, (name, right, toward) in zip(axes, _VIEWS):
        _draw_view(ax, x, tris, panel, bv, bf, right, toward)
        ax.set_title(name)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return atomic_write_bytes(Path(path), buf.getvalue())
