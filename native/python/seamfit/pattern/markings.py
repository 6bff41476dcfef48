"""Notches, grain lines, labels and internal lines carried through grading.

Notches are outline vertices (``notches[].vertex``): they move with the outline and stay on
their edge by construction; ``carry_markings`` checks it and reports each one's place along
its edge before and after. Everything else a panel carries in the plane (the grain line,
internal lines such as darts and pocket placements, cutouts, drill holes, the places of its
texts) is moved with the panel's parametrization: each point is located in a triangle of the
base pattern's mesh and taken to the same barycentric place in the graded triangle (a point
off the panel goes with its nearest triangle's affine map). The grain line keeps its base
direction (the fabric's grain does not turn), centred where its mapped ends' midpoint falls,
as long as they fall apart.

A point on the outline (within ``ON_EDGE_TOL_CM``; a dart's leg ending on the waist) keeps
its place along the same outline segment, so it stays on its edge. Reported: a point
inside the panel that ends up outside it (the outline moved past it), a notch no longer on
its edge's curve.
"""
from __future__ import annotations

import numpy as np

from .model import range_indices
from .refit import project_onto_curve

ON_EDGE_TOL_CM = 0.01        # 0.1 mm


def _barycentric(P: np.ndarray, A: np.ndarray) -> np.ndarray:
    """(n_points, n_triangles, 3) barycentric coordinates of P in each triangle A (T, 3, 2)."""
    a, b, c = A[:, 0], A[:, 1], A[:, 2]
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    det = np.where(np.abs(det) < 1e-18, 1e-18, det)
    d = P[:, None, :] - a[None, :, :]
    l1 = (d[..., 0] * v1[None, :, 1] - d[..., 1] * v1[None, :, 0]) / det[None, :]
    l2 = (v0[None, :, 0] * d[..., 1] - v0[None, :, 1] * d[..., 0]) / det[None, :]
    return np.stack([1.0 - l1 - l2, l1, l2], axis=-1)


def map_points(P, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Points P (n, 2) of the base triangles A (T, 3, 2) taken to the graded ones B."""
    P = np.atleast_2d(np.asarray(P, dtype=float))
    if len(P) == 0:
        return P.copy()
    w = _barycentric(P, A)
    inside = w.min(axis=-1)                      # > 0 inside; the largest: the nearest triangle
    t = np.argmax(inside, axis=1)
    wt = w[np.arange(len(P)), t]
    return np.einsum("pk,pkd->pd", wt, B[t])


def _dist_to_outline(P: np.ndarray, o: np.ndarray) -> np.ndarray:
    a, b = o, np.roll(o, -1, axis=0)
    e = b - a
    ee = np.maximum((e * e).sum(axis=1), 1e-18)
    t = np.clip(((P[:, None, :] - a[None]) * e[None]).sum(axis=-1) / ee[None], 0.0, 1.0)
    q = a[None] + t[..., None] * e[None]
    return np.linalg.norm(P[:, None, :] - q, axis=-1).min(axis=1)


def _on_outline(P: np.ndarray, o: np.ndarray):
    """For each point, its nearest outline segment i and the fraction t along it, and the distance."""
    a, b = o, np.roll(o, -1, axis=0)
    e = b - a
    ee = np.maximum((e * e).sum(axis=1), 1e-18)
    t = np.clip(((P[:, None, :] - a[None]) * e[None]).sum(axis=-1) / ee[None], 0.0, 1.0)
    d = np.linalg.norm(P[:, None, :] - (a[None] + t[..., None] * e[None]), axis=-1)
    i = np.argmin(d, axis=1)
    r = np.arange(len(P))
    return i, t[r, i], d[r, i]


def _inside(P: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Even-odd rule."""
    x, y = P[:, 0][:, None], P[:, 1][:, None]
    a, b = o[None, :, :], np.roll(o, -1, axis=0)[None, :, :]
    cross = (a[..., 1] > y) != (b[..., 1] > y)
    xint = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / np.where(b[..., 1] == a[..., 1], 1e-18,
                                                                              b[..., 1] - a[..., 1])
    return (cross & (x < xint)).sum(axis=1) % 2 == 1


def _edge_of(panel, v: int):
    n = len(panel.outline_cm)
    for e in panel.edges:
        idx = range_indices((e.start, e.end), n)
        if v in idx:
            return e, idx
    return None, None


def _fraction(o: np.ndarray, idx, v: int) -> float:
    pts = o[idx]
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    total = float(seg.sum())
    k = list(idx).index(v)
    return float(seg[:k].sum()) / total if total > 0 else 0.0


def carry_markings(base, graded, mesh, uv_new_cm) -> dict:
    """Move the markings of ``base``'s panels onto ``graded`` (its copy after grading, changed
    in place) with the mesh's map from ``mesh.uv_cm`` to ``uv_new_cm``. Returns the report:
    what was carried per panel, the notches' places along their edges, and ``left`` (points
    and notches that left their edge or their panel)."""
    uv0, uv1 = np.asarray(mesh.uv_cm, dtype=float), np.asarray(uv_new_cm, dtype=float)
    report = {"notches": [], "carried": {}, "left": []}
    for k, (pb, pg) in enumerate(zip(base.panels, graded.panels)):
        tri = mesh.triangles[np.asarray(mesh.triangle_panel) == k]
        A, B = uv0[tri], uv1[tri]
        ob, og = np.asarray(pb.outline_cm, dtype=float), np.asarray(pg.outline_cm, dtype=float)
        counts = {}

        def carry(pts, what):
            P = np.atleast_2d(np.asarray(pts, dtype=float))
            Q = map_points(P, A, B)
            # A point on the outline (a dart's leg ending on the waist) keeps its place along
            # the same outline segment: it stays on its edge.
            seg, t, d = _on_outline(P, ob)
            on_edge = d <= ON_EDGE_TOL_CM
            nxt = (seg + 1) % len(og)
            Q[on_edge] = og[seg[on_edge]] + t[on_edge, None] * (og[nxt[on_edge]] - og[seg[on_edge]])
            inside = _inside(P, ob)
            d_after = _dist_to_outline(Q, og)
            in_after = _inside(Q, og)
            for i in range(len(P)):
                if inside[i] and not on_edge[i] and not in_after[i] and d_after[i] > ON_EDGE_TOL_CM:
                    report["left"].append({"panel": pg.name, "what": what, "point": i, "problem": "left the panel",
                                           "distance_mm": round(10.0 * float(d_after[i]), 3)})
            counts[what.split("[")[0]] = counts.get(what.split("[")[0], 0) + len(P)
            return Q

        ex = pg.extra
        g = pb.extra.get("grain_line_cm")
        if g and len(g) == 2:
            P = np.asarray(g, dtype=float)
            Q = carry(P, "grain_line")
            direction = P[1] - P[0]
            length0 = float(np.linalg.norm(direction))
            if length0 > 0:
                mid = 0.5 * (Q[0] + Q[1])
                half = 0.5 * float(np.linalg.norm(Q[1] - Q[0])) * direction / length0
                Q = np.stack([mid - half, mid + half])
            ex["grain_line_cm"] = Q.tolist()
        if pb.extra.get("internal_lines"):
            lines = []
            for j, line in enumerate(pb.extra["internal_lines"]):
                new = dict(line)
                new["points_cm"] = carry(line["points_cm"], f"internal_lines[{j}]").tolist()
                lines.append(new)
            ex["internal_lines"] = lines
        if pb.extra.get("cutouts"):
            ex["cutouts"] = [carry(c, f"cutouts[{j}]").tolist() for j, c in enumerate(pb.extra["cutouts"])]
        if pb.extra.get("drill_holes_cm"):
            ex["drill_holes_cm"] = carry(pb.extra["drill_holes_cm"], "drill_holes").tolist()
        dxf = pb.extra.get("dxf")
        if isinstance(dxf, dict) and dxf.get("texts"):
            texts = []
            for t in dxf["texts"]:
                t = dict(t)
                try:
                    t["at_cm"] = carry([t["at_cm"]], "texts")[0].tolist()
                except (KeyError, TypeError, ValueError):
                    pass
                texts.append(t)
            ex["dxf"] = {**ex.get("dxf", {}), "texts": texts}
        if counts:
            report["carried"][pg.name] = counts
        for notch in pb.extra.get("notches") or []:
            v = int(notch.get("vertex", -1))
            e, idx = _edge_of(pg, v)
            if e is None:
                report["left"].append({"panel": pg.name, "what": "notch", "point": v, "problem": "on no edge"})
                continue
            ge = next(x for x in pg.edges if x.id == e.id)
            on, _ = project_onto_curve(ge, og[v:v + 1])
            off = 10.0 * float(np.linalg.norm(on[0] - og[v]))
            entry = {"panel": pg.name, "vertex": v, "edge": e.id,
                     "fraction_base": round(_fraction(ob, idx, v), 4),
                     "fraction_graded": round(_fraction(og, idx, v), 4), "off_edge_mm": round(off, 4)}
            report["notches"].append(entry)
            if off > 10.0 * ON_EDGE_TOL_CM:
                report["left"].append({"panel": pg.name, "what": "notch", "point": v, "problem": "off its edge",
                                       "distance_mm": round(off, 3)})
    return report
