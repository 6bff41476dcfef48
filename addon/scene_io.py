# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender data for seamfit's objects: patterns as collections of flat panel curves,
stitches as loose edges, garments as meshes. Results are always NEW datablocks; a
failure while building removes whatever was built, so the scene stays as it was.
"""
from __future__ import annotations

import json
from contextlib import contextmanager

import bpy
import numpy as np
from mathutils import Matrix

from . import compute

PATTERN_KEY = "seamfit_pattern"   # collection: the sewpat-1 JSON the objects came from
ROLE_KEY = "seamfit_role"         # collection: "pattern" | "graded" | "drape"
PANEL_KEY = "seamfit_panel"       # object: the panel's name in the pattern

# Precision Blender keeps for curve points (float32 in metres), in cm: an exported outline
# keeps the pattern's own float64 values where the curve was not edited.
_UNEDITED_CM = 1e-3


@contextmanager
def building():
    """Collect the datablocks made inside the block; on an exception remove them all."""
    made: list = []
    try:
        yield made
    except BaseException:
        for idb in reversed(made):
            try:
                coll = _data_collection(idb)
                if coll is not None and idb.name in coll:
                    coll.remove(idb)
            except ReferenceError:
                pass
        raise


def _data_collection(idb):
    for attr, typ in (("objects", bpy.types.Object), ("collections", bpy.types.Collection),
                      ("meshes", bpy.types.Mesh), ("curves", bpy.types.Curve),
                      ("materials", bpy.types.Material)):
        if isinstance(idb, typ):
            return getattr(bpy.data, attr)
    return None


def placement_matrix(placement) -> Matrix:
    m = Matrix.Identity(4)
    rot = np.asarray(placement.rotation, dtype=float)
    t = np.asarray(placement.translation_m, dtype=float)
    for i in range(3):
        for j in range(3):
            m[i][j] = float(rot[i, j])
        m[i][3] = float(t[i])
    return m


def _new_collection(context, name: str, made: list, parent=None) -> bpy.types.Collection:
    coll = bpy.data.collections.new(name)
    made.append(coll)
    (parent or context.scene.collection).children.link(coll)
    return coll


def _link(coll, obj, made):
    made.append(obj)
    coll.objects.link(obj)


# Viewport colours of the panels (Solid shading, Color: Object), so neighbours differ.
_PALETTE = [(0.90, 0.55, 0.35, 1.0), (0.35, 0.60, 0.85, 1.0), (0.55, 0.80, 0.45, 1.0),
            (0.85, 0.75, 0.35, 1.0), (0.70, 0.50, 0.80, 1.0), (0.40, 0.80, 0.80, 1.0)]


def _panel_curve(name: str, panel, made: list, index: int = 0) -> bpy.types.Object:
    cu = bpy.data.curves.new(name, "CURVE")
    made.append(cu)
    # A flat 2D curve: Blender fills its interior, so each panel reads as a piece of cloth.
    cu.dimensions = "2D"
    cu.fill_mode = "BOTH"
    sp = cu.splines.new("POLY")
    n = panel.n_vertices
    sp.points.add(n - 1)
    co = np.zeros((n, 4))
    co[:, :2] = 0.01 * panel.outline_cm
    co[:, 3] = 1.0
    sp.points.foreach_set("co", co.ravel())
    sp.use_cyclic_u = True
    obj = bpy.data.objects.new(name, cu)
    obj.matrix_world = placement_matrix(panel.placement)
    obj[PANEL_KEY] = panel.name
    obj["seamfit_corners"] = [int(i) for i in panel.corners]
    obj.show_name = True
    obj.color = _PALETTE[index % len(_PALETTE)]
    return obj


def _stitch_object(name: str, pattern, made: list) -> bpy.types.Object:
    """Loose edges joining matching points of both sides of every stitch: Blender's cloth
    sewing convention (a cloth modifier with sewing springs pulls them together)."""
    verts, edges, stitch_of_edge = [], [], []
    for k, st in enumerate(pattern.stitches):
        a, b = compute.stitch_pairs_world(pattern, st)
        for pa, pb in zip(a, b):
            i = len(verts)
            verts += [tuple(pa), tuple(pb)]
            edges.append((i, i + 1))
            stitch_of_edge.append(k)
    me = bpy.data.meshes.new(name)
    made.append(me)
    me.from_pydata(verts, edges, [])
    attr = me.attributes.new("stitch", "INT", "EDGE")
    if stitch_of_edge:
        attr.data.foreach_set("value", np.asarray(stitch_of_edge, dtype=np.int32))
    me.update()
    obj = bpy.data.objects.new(name, me)
    obj.display_type = "WIRE"
    obj.show_in_front = True
    obj.hide_render = True
    return obj


def store_summary(coll, pattern, role: str, source: str = "", body: str = "") -> None:
    """What the panels draw about a pattern (names, corners, stitch lengths)."""
    info = coll.seamfit
    info.role = role
    info.source = source
    info.body = body
    info.panels.clear()
    for pn in pattern.panels:
        it = info.panels.add()
        it.name = pn.name
        it.n_vertices = pn.n_vertices
        it.n_corners = len(pn.corners)
        it.area_cm2 = abs(pn.signed_area_cm2())
    info.stitches.clear()
    for k, st in enumerate(pattern.stitches):
        la, lb = compute.stitch_lengths_cm(pattern, st)
        it = info.stitches.add()
        it.name = f"{k}: {st.a.panel} - {st.b.panel}"
        it.panel_a, it.panel_b = st.a.panel, st.b.panel
        it.length_a_cm, it.length_b_cm = la, lb
        it.gathered = bool(st.gathered)


def build_pattern(context, pattern, name: str, role: str = "pattern", source: str = "",
                  body: str = "", parent=None, made: list | None = None) -> bpy.types.Collection:
    """A new collection holding one flat curve object per panel and the stitches."""
    if made is None:
        with building() as made:
            return build_pattern(context, pattern, name, role, source, body, parent, made)
    coll = _new_collection(context, name, made, parent)
    coll[PATTERN_KEY] = compute.pattern_to_json(pattern)
    coll[ROLE_KEY] = role
    for k, pn in enumerate(pattern.panels):
        _link(coll, _panel_curve(pn.name, pn, made, k), made)
    if pattern.stitches:
        _link(coll, _stitch_object(f"{name} stitches", pattern, made), made)
    store_summary(coll, pattern, role, source, body)
    return coll


def is_pattern_collection(coll) -> bool:
    return coll is not None and PATTERN_KEY in coll


def panel_objects(coll) -> dict[str, bpy.types.Object]:
    return {o[PANEL_KEY]: o for o in coll.objects if PANEL_KEY in o}


def pattern_from_collection(coll):
    """The pattern as the scene shows it now: the stored pattern with each panel's
    outline and placement read back from its curve object (so edits are exported)."""
    if not is_pattern_collection(coll):
        raise compute.AddonError(f"collection {coll.name!r} holds no seamfit pattern")
    pattern = compute.pattern_from_json(coll[PATTERN_KEY], source=f"collection {coll.name!r}")
    # Where it came from: seamfit then refuses to export over the user's original file.
    pattern.source_file = coll.seamfit.source or None
    objs = panel_objects(coll)
    for pn in pattern.panels:
        obj = objs.get(pn.name)
        if obj is None:
            raise compute.AddonError(f"pattern {coll.name!r}: the object of panel {pn.name!r} was deleted")
        if obj.type != "CURVE" or len(obj.data.splines) != 1:
            raise compute.AddonError(f"panel {pn.name!r}: its object must stay one curve with one spline")
        pts = obj.data.splines[0].points
        if len(pts) != pn.n_vertices:
            raise compute.AddonError(
                f"panel {pn.name!r}: the outline has {len(pts)} points but the pattern's stitches and "
                f"curves refer to {pn.n_vertices}; move points instead of adding or deleting them")
        co = np.zeros(len(pts) * 4)
        pts.foreach_get("co", co)
        loc, rot, scale = obj.matrix_world.decompose()
        uv = co.reshape(-1, 4)[:, :2] * np.array(scale[:2]) * 100.0
        keep = np.linalg.norm(uv - pn.outline_cm, axis=1) < _UNEDITED_CM
        pn.outline_cm = np.where(keep[:, None], pn.outline_cm, uv)
        R = np.array(rot.to_matrix())
        t = np.array(loc)
        if not (np.allclose(R, pn.placement.rotation, atol=1e-6)
                and np.allclose(t, pn.placement.translation_m, atol=1e-6)):
            pn.placement.rotation = R
            pn.placement.translation_m = t
    return pattern


def remove_collection(coll) -> None:
    """Delete a collection made by seamfit and the data only it used."""
    for obj in list(coll.objects):
        data = obj.data
        bpy.data.objects.remove(obj)
        if data is not None and data.users == 0:
            (bpy.data.curves if isinstance(data, bpy.types.Curve) else bpy.data.meshes).remove(data)
    bpy.data.collections.remove(coll)


def json_summary(coll) -> dict:
    return json.loads(coll[PATTERN_KEY])


# ---------------------------------------------------------------------------
# Garments (drape and grading results)

def stretch_colors(ratio: np.ndarray, span: float = 0.1) -> np.ndarray:
    """Blue (compressed) - white (unstretched) - red (stretched by ``span`` or more)."""
    t = np.clip((np.asarray(ratio) - 1.0) / span, -1.0, 1.0)
    rgba = np.ones((len(t), 4))
    pos, neg = t > 0, t < 0
    rgba[pos, 1] -= t[pos]
    rgba[pos, 2] -= t[pos]
    rgba[neg, 0] += t[neg]
    rgba[neg, 1] += t[neg]
    return rgba


def _stretch_material(made: list) -> bpy.types.Material:
    mat = bpy.data.materials.new("seamfit stretch")
    made.append(mat)
    if bpy.app.version < (5, 0, 0):     # always on (and deprecated) from 5.0
        mat.use_nodes = True
    nt = mat.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "stretch_color"
    nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def garment_mesh(name: str, g, made: list) -> bpy.types.Object:
    """A mesh of the garment: triangles, loose sewing edges (Blender's cloth convention),
    the pattern as UVs, the panel of each face and the stretch ratio per vertex."""
    x = np.asarray(g.x, dtype=np.float64)
    tri = np.asarray(g.triangles, dtype=np.int64)
    pairs = np.asarray(g.sewing_pairs, dtype=np.int64).reshape(-1, 2)
    me = bpy.data.meshes.new(name)
    made.append(me)
    me.vertices.add(len(x))
    me.vertices.foreach_set("co", x.astype(np.float32).ravel())
    me.loops.add(3 * len(tri))
    me.loops.foreach_set("vertex_index", tri.astype(np.int32).ravel())
    me.polygons.add(len(tri))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(tri), 3, dtype=np.int32))
    if len(pairs):
        # Sewing pairs as loose edges; update(calc_edges=True) keeps them and adds the face edges.
        me.edges.add(len(pairs))
        me.edges.foreach_set("vertices", pairs.astype(np.int32).ravel())
    me.update(calc_edges=True)
    uv = me.uv_layers.new(name="pattern")
    uv_loop = (0.01 * np.asarray(g.uv_cm))[tri.ravel()]
    uv.data.foreach_set("uv", uv_loop.astype(np.float32).ravel())
    panel = me.attributes.new("panel", "INT", "FACE")
    panel.data.foreach_set("value", np.asarray(g.triangle_panel, dtype=np.int32))
    if len(pairs) and g.pair_stitch is not None:
        # Blender may reorder edges when it derives the face edges: find each pair's edge.
        ev = np.empty(2 * len(me.edges), dtype=np.int64)
        me.edges.foreach_get("vertices", ev)
        nv = len(x)
        keys = np.sort(ev.reshape(-1, 2), axis=1) @ np.array([nv, 1])
        pkeys = np.sort(pairs, axis=1) @ np.array([nv, 1])
        order = np.argsort(keys)
        where = order[np.searchsorted(keys, pkeys, sorter=order)]
        values = np.full(len(me.edges), -1, dtype=np.int32)
        values[where] = np.asarray(g.pair_stitch, dtype=np.int32)
        me.attributes.new("stitch", "INT", "EDGE").data.foreach_set("value", values)
    if g.stretch is not None:
        ratio = me.attributes.new("stretch_ratio", "FLOAT", "POINT")
        ratio.data.foreach_set("value", np.asarray(g.stretch, dtype=np.float32))
        col = me.color_attributes.new("stretch_color", "FLOAT_COLOR", "POINT")
        col.data.foreach_set("color", stretch_colors(g.stretch).astype(np.float32).ravel())
        me.color_attributes.active_color = col
        me.materials.append(_stretch_material(made))
    obj = bpy.data.objects.new(name, me)
    obj["seamfit_panels"] = list(g.panel_names)
    return obj


def build_sewn(context, out, name: str) -> bpy.types.Collection:
    """A new collection with the sewn-ready mesh of a pattern, flat at the panel placements."""
    with building() as made:
        coll = _new_collection(context, name, made)
        coll[PATTERN_KEY] = out.pattern_json
        coll[ROLE_KEY] = "drape"
        coll.seamfit.role = "mesh"
        _link(coll, garment_mesh(name, out.garment, made), made)
    return coll


def _store_fit(coll, fit: dict | None) -> None:
    f = coll.seamfit.fit
    f.valid = bool(fit)
    for key in ("bust", "waist", "hip"):
        has = bool(fit) and key in fit
        setattr(f, f"has_{key}", has)
        setattr(f, key, float(fit[key]) if has else 0.0)


def build_drape(context, out, name: str, body: str) -> bpy.types.Collection:
    """A new collection with the draped garment (``out``: compute.DrapeOutput)."""
    with building() as made:
        coll = _new_collection(context, name, made)
        coll[PATTERN_KEY] = out.pattern_json
        coll[ROLE_KEY] = "drape"
        coll.seamfit.role = "drape"
        coll.seamfit.body = body
        _link(coll, garment_mesh(f"{name} garment", out.garment, made), made)
        _store_fit(coll, out.fit)
    return coll


def build_graded(context, out, name: str, base_collection: str, body: str) -> bpy.types.Collection:
    """A new collection with the graded pattern's panel curves and stitches, and the
    garment sewn from it draped on the target body (``out``: compute.GradeOutput)."""
    pattern = compute.pattern_from_json(out.pattern_json, source="graded pattern")
    with building() as made:
        coll = build_pattern(context, pattern, name, role="graded", body=body, made=made)
        coll["seamfit_base"] = base_collection
        if out.garment is not None:
            _link(coll, garment_mesh(f"{name} garment", out.garment, made), made)
        _store_fit(coll, out.fit)
        coll.seamfit.objective = float(out.objective)
        coll.seamfit.iterations = int(out.iterations)
        coll.seamfit.method = out.method
    return coll
