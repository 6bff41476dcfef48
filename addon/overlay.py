# SPDX-License-Identifier: GPL-3.0-or-later
"""Viewport overlay: panel corners as dots and stitch lengths as labels, for the patterns
in the scene. What to draw is computed by ``overlay_items`` (testable without a GPU);
the draw callbacks only exist when Blender has a display."""
from __future__ import annotations

import bpy
import numpy as np

from . import scene_io

_handles: list = []
_parsed: dict = {}


def _stored(coll) -> tuple[list, dict]:
    """Side A (panel, range) of every stitch and each panel's outline (local m), parsed once
    per stored pattern (Apply Curve Edits stores an edited one)."""
    text = coll[scene_io.PATTERN_KEY]
    key = (coll.name, hash(text))
    if key not in _parsed:
        import json
        if len(_parsed) > 32:
            _parsed.clear()
        d = json.loads(text)
        outlines = {}
        for p in d["panels"]:
            o = np.zeros((len(p["outline_cm"]), 4))
            o[:, :2], o[:, 3] = 0.01 * np.asarray(p["outline_cm"], dtype=float), 1.0
            outlines[p["name"]] = o
        _parsed[key] = ([(s["a"]["panel"], tuple(s["a"]["range"])) for s in d["stitches"]], outlines)
    return _parsed[key]


def overlay_items(scene) -> dict:
    """{"corners": (n, 3) world points, "labels": [(world point, text)]} for every visible
    pattern collection of ``scene``."""
    corners, labels = [], []
    for coll in bpy.data.collections:
        if not scene_io.is_pattern_collection(coll) or coll.seamfit.role in ("drape", "mesh"):
            continue
        objs = scene_io.panel_objects(coll)
        ranges, outlines = _stored(coll)
        pts_world = {}
        for name, obj in objs.items():
            if obj.type != "CURVE" or not obj.visible_get() or name not in outlines:
                continue
            w = (outlines[name] @ np.array(obj.matrix_world).T)[:, :3]
            pts_world[name] = w
            idx = [i for i in obj.get("seamfit_corners", []) if 0 <= i < len(w)]
            corners.extend(w[idx])
        for (panel, (i0, i1)), info in zip(ranges, coll.seamfit.stitches):
            w = pts_world.get(panel)
            if w is None:
                continue
            n = len(w)
            mid = (i0 + ((i1 - i0) % n) // 2) % n
            text = f"{info.length_a_cm:.1f}"
            if abs(info.length_a_cm - info.length_b_cm) > 0.05:
                text += f"/{info.length_b_cm:.1f}"
            labels.append((w[mid], text + " cm"))
    return {"corners": np.asarray(corners).reshape(-1, 3), "labels": labels}


def legend_items(scene) -> list[dict]:
    """The viewport legend: one colour bar per visible garment with a stretch map (its
    range in %, what it shows, the data's own minimum and maximum)."""
    items = []
    for obj in scene_io.garments(scene):
        if not obj.visible_get() or not obj.get("seamfit_stretch"):
            continue
        st = obj["seamfit_stretch"]
        label = scene_io.STRETCH_MEASURES[st["measure"]][1]
        low, high = scene_io.legend_label(st["span_pct"])
        items.append({"object": obj.name, "span_pct": float(st["span_pct"]), "low": low, "high": high,
                      "title": f"{obj.name}: {label} (%), {st['min_pct']:+.1f} to {st['max_pct']:+.1f}",
                      "colors": scene_io.stretch_colors(np.linspace(-st["span_pct"], st["span_pct"], 11),
                                                        st["span_pct"])})
    return items


def _draw_legend(ctx) -> None:
    import blf
    import gpu
    from gpu_extras.batch import batch_for_shader
    x0, y, w, h = 20, 40, 220, 12
    shader = gpu.shader.from_builtin("SMOOTH_COLOR")
    for item in reversed(legend_items(ctx.scene)):
        cols = item["colors"]
        n = len(cols)
        pos, col, idx = [], [], []
        for k in range(n):
            x = x0 + w * k / (n - 1)
            pos += [(x, y), (x, y + h)]
            col += [tuple(cols[k]), tuple(cols[k])]
            if k:
                a = 2 * (k - 1)
                idx += [(a, a + 2, a + 3), (a, a + 3, a + 1)]
        batch_for_shader(shader, "TRIS", {"pos": pos, "color": col}, indices=idx).draw(shader)
        blf.size(0, 11)
        blf.color(0, 1.0, 1.0, 1.0, 1.0)
        blf.position(0, x0, y - 13, 0)
        blf.draw(0, item["low"])
        blf.position(0, x0 + w - blf.dimensions(0, item["high"])[0], y - 13, 0)
        blf.draw(0, item["high"])
        blf.position(0, x0, y + h + 5, 0)
        blf.draw(0, item["title"])
        y += h + 45


def _draw_view():
    ctx = bpy.context
    s = getattr(ctx.scene, "seamfit", None)
    if s is None or not s.show_overlay:
        return
    import gpu
    from gpu_extras.batch import batch_for_shader
    items = overlay_items(ctx.scene)
    if not len(items["corners"]):
        return
    shader = gpu.shader.from_builtin("POINT_UNIFORM_COLOR")
    batch = batch_for_shader(shader, "POINTS", {"pos": [tuple(p) for p in items["corners"]]})
    gpu.state.point_size_set(7.0)
    shader.uniform_float("color", (1.0, 0.45, 0.1, 1.0))
    batch.draw(shader)
    gpu.state.point_size_set(1.0)


def _draw_pixel():
    ctx = bpy.context
    s = getattr(ctx.scene, "seamfit", None)
    if s is None or ctx.region_data is None:
        return
    if s.show_legend:
        _draw_legend(ctx)
    if not s.show_overlay:
        return
    import blf
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    font = 0
    blf.size(font, 12)
    blf.color(font, 1.0, 0.9, 0.5, 1.0)
    for pos, text in overlay_items(ctx.scene)["labels"]:
        xy = location_3d_to_region_2d(ctx.region, ctx.region_data, pos)
        if xy is not None:
            blf.position(font, xy[0], xy[1], 0)
            blf.draw(font, text)


def register():
    if bpy.app.background:
        return
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_view, (), "WINDOW", "POST_VIEW"))
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_pixel, (), "WINDOW", "POST_PIXEL"))


def unregister():
    while _handles:
        bpy.types.SpaceView3D.draw_handler_remove(_handles.pop(), "WINDOW")
