# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender data for seamfit's objects: patterns as collections of flat panel curves,
stitches as loose edges, garments as meshes.

Each result (the sewn mesh, the drape or the grading of a pattern on a body, the compare
view of a grading) has a slot: running it again replaces the result in its slot, and
running it again on the same inputs keeps the existing result untouched, so repeated runs
leave one result per slot. A failure while building removes whatever was built, and the
previous result is only removed once its replacement is complete, so the scene stays as it
was.
"""
from __future__ import annotations

import json
from contextlib import contextmanager

import bpy
import numpy as np
from mathutils import Matrix

from . import compute, panel_curves

PATTERN_KEY = "seamfit_pattern"   # collection: the sewpat-1 JSON the objects came from
ROLE_KEY = "seamfit_role"         # collection: "pattern" | "graded" | "drape"
PANEL_KEY = "seamfit_panel"       # object: the panel's name in the pattern
SLOT_KEY = "seamfit_slot"         # collection: which result it is ("adjust|<pattern>|<body>", ...)
INPUTS_KEY = "seamfit_inputs"     # collection: content hash of the inputs that made it
CONTENTS_KEY = "seamfit_contents" # collection: the objects it was made with, to tell if it is intact
STRETCH_MATERIAL_KEY = "seamfit_stretch_material"
DISPLAY_MODIFIERS = ("seamfit refine", "seamfit outside body")
# Drawn this far outside the body at least (the simulation keeps vertices off the body, but
# a coarse flat triangle spanning a curved body cuts into it between its vertices).
DISPLAY_CLEARANCE_M = 0.002
# Display refinement: edges are split until they are about this long.
_DISPLAY_EDGE_M = 0.008

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
    coll["seamfit_name"] = name     # Blender adds ".001" while an older result holds the name
    made.append(coll)
    (parent or context.scene.collection).children.link(coll)
    return coll


def _link(coll, obj, made):
    if obj not in made:
        made.append(obj)
    coll.objects.link(obj)


def _new_object(name: str, data, made: list) -> bpy.types.Object:
    obj = bpy.data.objects.new(name, data)
    obj["seamfit_name"] = name      # see _new_collection
    made.append(obj)
    return obj


# Viewport colours of the panels (Solid shading, Color: Object), so neighbours differ.
_PALETTE = [(0.90, 0.55, 0.35, 1.0), (0.35, 0.60, 0.85, 1.0), (0.55, 0.80, 0.45, 1.0),
            (0.85, 0.75, 0.35, 1.0), (0.70, 0.50, 0.80, 1.0), (0.40, 0.80, 0.80, 1.0)]


def _panel_curve(name: str, panel, made: list, index: int = 0) -> bpy.types.Object:
    cu = bpy.data.curves.new(name, "CURVE")
    made.append(cu)
    # A flat 2D curve: Blender fills its interior, so each panel reads as a piece of cloth.
    cu.dimensions = "2D"
    cu.fill_mode = "BOTH"
    owner = panel_curves.build_spline(cu, panel)
    obj = _new_object(name, cu, made)
    obj.matrix_world = placement_matrix(panel.placement)
    obj[PANEL_KEY] = panel.name
    obj["seamfit_corners"] = [int(i) for i in panel.corners]
    panel_curves.remember(obj, owner)
    obj.show_name = True
    obj.color = _PALETTE[index % len(_PALETTE)]
    return obj


def _stitch_object(name: str, pattern, made: list) -> bpy.types.Object:
    """Loose edges joining matching points of both sides of every stitch: Blender's cloth
    sewing convention (a cloth modifier with sewing springs pulls them together)."""
    obj = _new_object(name, _stitch_mesh(name, pattern, made), made)
    obj.display_type = "WIRE"
    obj.show_in_front = True
    obj.hide_render = True
    return obj


def _stitch_mesh(name: str, pattern, made: list) -> bpy.types.Mesh:
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
    return me


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
                  body: str = "", parent=None, made: list | None = None,
                  with_stitches: bool = True) -> bpy.types.Collection:
    """A new collection holding one flat curve object per panel and the stitches."""
    if made is None:
        with building() as made:
            return build_pattern(context, pattern, name, role, source, body, parent, made, with_stitches)
    coll = _new_collection(context, name, made, parent)
    coll[PATTERN_KEY] = compute.pattern_to_json(pattern)
    coll[ROLE_KEY] = role
    for k, pn in enumerate(pattern.panels):
        _link(coll, _panel_curve(pn.name, pn, made, k), made)
    if pattern.stitches and with_stitches:
        _link(coll, _stitch_object(f"{name} stitches", pattern, made), made)
    store_summary(coll, pattern, role, source, body)
    return coll


def is_pattern_collection(coll) -> bool:
    return coll is not None and PATTERN_KEY in coll


def panel_objects(coll) -> dict[str, bpy.types.Object]:
    return {o[PANEL_KEY]: o for o in coll.objects if PANEL_KEY in o}


def pattern_from_collection(coll):
    """The pattern as the scene shows it now: the stored pattern with each panel's curves
    (points and handles) and placement read back from its object, so edits reach export,
    drape and adjust. Edited edges are sampled again and the stitches stay on them; an
    edited pattern is validated as a file is (one line naming the panel or stitch)."""
    pattern, edited = _read_collection(coll)
    if edited:
        compute.check_edited(pattern, f"pattern {coll.name!r}")
    return pattern


def _read_collection(coll):
    """(pattern as the scene shows it, names of the panels whose curves were edited)."""
    if not is_pattern_collection(coll):
        raise compute.AddonError(f"collection {coll.name!r} holds no seamfit pattern")
    pattern = compute.pattern_from_json(coll[PATTERN_KEY], source=f"collection {coll.name!r}")
    # Where it came from: seamfit then refuses to export over the user's original file.
    pattern.source_file = coll.seamfit.source or None
    objs = panel_objects(coll)
    changes, edited = {}, []
    for pn in pattern.panels:
        obj = objs.get(pn.name)
        if obj is None:
            raise compute.AddonError(f"pattern {coll.name!r}: the object of panel {pn.name!r} was deleted")
        loc, rot, scale = obj.matrix_world.decompose()
        if obj.type == "CURVE" and len(obj.data.splines) == 1 and obj.data.splines[0].type == "POLY":
            outline, per_edge = _poly_outline(obj, pn, scale), {}
        else:
            outline, per_edge = panel_curves.read_panel(obj, pn, scale)
        if outline is not None and not np.array_equal(outline, pn.outline_cm):
            pn.outline_cm = outline
            edited.append(pn.name)
        if per_edge:
            changes[pn.name] = per_edge
            edited.append(pn.name)
        R = np.array(rot.to_matrix())
        t = np.array(loc)
        if not (np.allclose(R, pn.placement.rotation, atol=1e-6)
                and np.allclose(t, pn.placement.translation_m, atol=1e-6)):
            pn.placement.rotation = R
            pn.placement.translation_m = t
    if changes:
        pattern = compute.edit_pattern(pattern, changes)
    return pattern, edited


def _poly_outline(obj, pn, scale) -> np.ndarray:
    """The outline of a panel drawn as a poly curve (scenes saved before panels were Bezier
    curves): one curve point per outline point."""
    pts = obj.data.splines[0].points
    if len(pts) != pn.n_vertices:
        raise compute.AddonError(
            f"panel {pn.name!r}: the outline has {len(pts)} points but the pattern's stitches and "
            f"curves refer to {pn.n_vertices}; move points instead of adding or deleting them")
    co = np.zeros(len(pts) * 4)
    pts.foreach_get("co", co)
    uv = co.reshape(-1, 4)[:, :2] * np.array(scale[:2]) * 100.0
    keep = np.linalg.norm(uv - pn.outline_cm, axis=1) < panel_curves.UNEDITED_CM
    return np.where(keep[:, None], pn.outline_cm, uv)


def apply_edits(coll) -> tuple[list[str], list[str]]:
    """Hold the pattern as edited in the scene: the collection stores it (the file it came
    from is never touched), the edited panels are drawn again from their new edges, the
    stitches and the panel list follow. Returns (edited panels, validation warnings)."""
    pattern, edited = _read_collection(coll)
    warnings = compute.check_edited(pattern, f"pattern {coll.name!r}") if edited else []
    objs = panel_objects(coll)
    for name in dict.fromkeys(edited):
        pn, obj = pattern.panel(name), objs[name]
        obj.data.splines.clear()
        owner = panel_curves.build_spline(obj.data, pn)
        obj.matrix_world = placement_matrix(pn.placement)      # a scale is in the outline now
        obj["seamfit_corners"] = [int(i) for i in pn.corners]
        panel_curves.remember(obj, owner)
    if edited:
        _redraw_stitches(coll, pattern)
    coll[PATTERN_KEY] = compute.pattern_to_json(pattern)
    info = coll.seamfit
    store_summary(coll, pattern, info.role, info.source, info.body)
    return list(dict.fromkeys(edited)), warnings


def _redraw_stitches(coll, pattern, add: bool = False) -> None:
    """The stitch object of a pattern collection drawn again from ``pattern``'s stitches
    (with ``add``, made when the collection has none)."""
    for obj in coll.objects:
        if obj.type == "MESH" and PANEL_KEY not in obj and "stitch" in obj.data.attributes:
            old = obj.data
            obj.data = _stitch_mesh(old.name, pattern, [])
            if old.users == 0:
                bpy.data.meshes.remove(old)
            obj.data.name = obj.get("seamfit_name", obj.name)
            return
    if add and pattern.stitches:
        with building() as made:
            _link(coll, _stitch_object(f"{coll.name} stitches", pattern, made), made)


def set_stitches(coll, pattern) -> None:
    """Hold ``pattern`` (the collection's pattern with new stitches) in the collection: the
    stitch object and the panel's stitch list follow."""
    _redraw_stitches(coll, pattern, add=True)
    coll[PATTERN_KEY] = compute.pattern_to_json(pattern)
    info = coll.seamfit
    store_summary(coll, pattern, info.role, info.source, info.body)


def remove_collection(coll, foreign_to=None) -> None:
    """Delete a collection made by seamfit, its child collections and the data only they
    used (the shared stretch material stays). Objects and collections the user put in it
    are moved to ``foreign_to`` (the collection replacing it), or else to the scene."""
    keep_in = foreign_to if foreign_to is not None else bpy.context.scene.collection
    for child in list(coll.children):
        if "seamfit_name" in child or ROLE_KEY in child:
            remove_collection(child, foreign_to)
        else:
            coll.children.unlink(child)
            if child.name not in keep_in.children:
                keep_in.children.link(child)
    for obj in list(coll.objects):
        if "seamfit_name" not in obj and PANEL_KEY not in obj and "seamfit_panels" not in obj:
            coll.objects.unlink(obj)
            if obj.name not in keep_in.objects:
                keep_in.objects.link(obj)
            continue
        data = obj.data
        bpy.data.objects.remove(obj)
        if data is not None and data.users == 0:
            (bpy.data.curves if isinstance(data, bpy.types.Curve) else bpy.data.meshes).remove(data)
    bpy.data.collections.remove(coll)


# ---------------------------------------------------------------------------
# Result slots: one result per slot, replaced by a re-run

def slot_name(kind: str, *parts: str) -> str:
    return "|".join([kind, *parts])


def find_slot(slot: str):
    for coll in bpy.data.collections:
        if coll.get(SLOT_KEY) == slot:
            return coll
    return None


def _contents(coll) -> list[str]:
    return sorted(o.name for o in coll.all_objects)


def is_intact(coll) -> bool:
    """Whether a result still holds every object it was made with."""
    stored = coll.get(CONTENTS_KEY)
    return stored is not None and sorted(stored) == _contents(coll)


def reusable(slot: str, inputs_key: str):
    """The result of ``slot`` when it was made from the same inputs and is intact: running
    again then changes nothing in the scene."""
    coll = find_slot(slot)
    if coll is not None and coll.get(INPUTS_KEY) == inputs_key and is_intact(coll):
        return coll
    return None


def place_result(context, slot: str, inputs_key: str, name: str, build, keep: bool = False):
    """Build a result with ``build(context, name, made) -> collection`` and put it in
    ``slot``: the previous result of the slot is removed once the new one is complete, and
    the new one takes its name and its objects' names. With ``keep`` the previous result
    stays, out of the slot (it is never replaced after that)."""
    old = find_slot(slot)
    with building() as made:
        coll = build(context, name, made)
    if old is not None:
        if keep:
            del old[SLOT_KEY]
        else:
            remove_collection(old, foreign_to=coll)
            # The names the old result held are free now.
            for c in [coll, *coll.children_recursive]:
                c.name = c.get("seamfit_name", c.name)
            for obj in coll.all_objects:
                want = obj.get("seamfit_name", obj.name)
                obj.name = want
                if obj.data is not None and obj.type in {"MESH", "CURVE", "FONT"}:
                    obj.data.name = want
    coll[SLOT_KEY] = slot
    coll[INPUTS_KEY] = inputs_key
    coll[CONTENTS_KEY] = _contents(coll)
    return coll


def json_summary(coll) -> dict:
    return json.loads(coll[PATTERN_KEY])


# ---------------------------------------------------------------------------
# Garments (drape and grading results)

# What the stretch map shows (the colour attribute is made from the stored values).
STRETCH_MEASURES = {
    "EDGE": ("stretch_ratio", "Edge stretch",
             "Edge length on the body over its length in the pattern, averaged per vertex (Wang 2018, Fig. 8)"),
    "PRINCIPAL": ("strain_max_pct_point", "Largest principal strain",
                  "The larger principal strain of the fabric around each vertex"),
}


def strain_pct(values, measure: str = "EDGE") -> np.ndarray:
    """Strain in % of the stored values: stretch ratio - 1, or the principal strain."""
    v = np.asarray(values, dtype=np.float64)
    return 100.0 * (v - 1.0) if measure == "EDGE" else v


_NICE = (0.5, 1.0, 2.0, 2.5, 5.0, 10.0, 15.0, 20.0, 25.0, 50.0, 100.0)


def auto_span_pct(strain: np.ndarray) -> float:
    """The colour range (±span, %) chosen from the data: the smallest round number that
    holds 99 % of the vertices, so a few outliers do not wash the map out."""
    a = np.abs(np.asarray(strain, dtype=np.float64))
    a = a[np.isfinite(a)]
    q = float(np.percentile(a, 99.0)) if len(a) else 0.0
    return next((n for n in _NICE if q <= n), _NICE[-1])


def stretch_colors(strain_pct_values: np.ndarray, span_pct: float = 10.0) -> np.ndarray:
    """Blue (compressed by ``span_pct`` % or more) - white (unstretched) - red (stretched
    by ``span_pct`` % or more)."""
    t = np.clip(np.asarray(strain_pct_values, dtype=np.float64) / max(float(span_pct), 1e-9), -1.0, 1.0)
    rgba = np.ones((len(t), 4))
    pos, neg = t > 0, t < 0
    rgba[pos, 1] -= t[pos]
    rgba[pos, 2] -= t[pos]
    rgba[neg, 0] += t[neg]
    rgba[neg, 1] += t[neg]
    return rgba


def stretch_material() -> bpy.types.Material:
    """The one material of every stretch map (it shows each mesh's own colour attribute)."""
    for mat in bpy.data.materials:
        if mat.get(STRETCH_MATERIAL_KEY):
            return mat
    mat = bpy.data.materials.new("seamfit stretch")
    mat[STRETCH_MATERIAL_KEY] = True
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
    the pattern as UVs, the panel of each face, the stretch ratio per vertex and the
    principal strains."""
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
        smax, smin, vmax = compute.principal_strains_pct(g.uv_cm, x, tri)
        me.attributes.new("strain_max_pct", "FLOAT", "FACE").data.foreach_set("value", smax.astype(np.float32))
        me.attributes.new("strain_min_pct", "FLOAT", "FACE").data.foreach_set("value", smin.astype(np.float32))
        me.attributes.new("strain_max_pct_point", "FLOAT", "POINT").data.foreach_set(
            "value", vmax.astype(np.float32))
        col = me.color_attributes.new("stretch_color", "FLOAT_COLOR", "POINT")
        me.color_attributes.active_color = col
        me.materials.append(stretch_material())
    obj = _new_object(name, me, made)
    obj["seamfit_panels"] = list(g.panel_names)
    return obj


def stretch_values(obj) -> np.ndarray | None:
    """Strain in % of the measure the scene's stretch map shows, per vertex."""
    s = bpy.context.scene.seamfit
    attr_name = STRETCH_MEASURES[s.stretch_measure][0]
    attr = obj.data.attributes.get(attr_name)
    if attr is None:
        return None
    v = np.empty(len(obj.data.vertices), dtype=np.float32)
    attr.data.foreach_get("value", v)
    return strain_pct(v, s.stretch_measure)


def color_stretch(obj, scene=None) -> tuple[float, float, float] | None:
    """Colour a garment by the scene's stretch map settings; (span, data min, data max) in %,
    also stored on the object for the legends."""
    scene = scene or bpy.context.scene
    s = scene.seamfit
    if obj.type != "MESH" or "stretch_color" not in obj.data.color_attributes:
        return None
    strain = stretch_values(obj)
    if strain is None or not len(strain):
        return None
    span = auto_span_pct(strain) if s.stretch_range == "AUTO" else float(s.stretch_span_pct)
    col = obj.data.color_attributes["stretch_color"]
    col.data.foreach_set("color", stretch_colors(strain, span).astype(np.float32).ravel())
    obj.data.update()
    obj["seamfit_stretch"] = {"span_pct": span, "min_pct": float(strain.min()), "max_pct": float(strain.max()),
                              "measure": s.stretch_measure}
    legend = legend_of(obj)
    if legend is not None:
        _update_legend(legend, span, s.stretch_measure)
    return span, float(strain.min()), float(strain.max())


def garments(scene=None) -> list:
    """Every garment mesh with a stretch map."""
    return [o for o in bpy.data.objects
            if o.type == "MESH" and "stretch_color" in o.data.color_attributes and "seamfit_stretch" in o]


def recolor_all(scene=None) -> None:
    for obj in garments(scene):
        color_stretch(obj, scene)


def legend_label(span: float) -> tuple[str, str]:
    return f"-{span:g} %", f"+{span:g} %"


def _legend_text(name: str, text: str, size: float, made: list, coll, parent, location, align="CENTER"):
    cu = bpy.data.curves.new(name, "FONT")
    made.append(cu)
    cu.body = text
    cu.size = size
    cu.align_x = align
    cu.align_y = "CENTER"
    # The stretch material reads a colour attribute text has none of: black text, no other material.
    cu.materials.append(stretch_material())
    obj = _new_object(name, cu, made)
    _link(coll, obj, made)
    obj.parent = parent
    obj.location = location
    return obj


def _legend_object(name: str, garment, coll, made: list) -> bpy.types.Object:
    """A colour bar beside the garment, upright and facing the front (-Y), with its range
    written under it: the legend of the stretch map in renders as in the viewport."""
    n = 21
    w, h, text = 0.30, 0.04, 0.035
    xs = np.linspace(-0.5 * w, 0.5 * w, n)
    verts = [(x, 0.0, z) for x in xs for z in (0.0, h)]
    faces = [(2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1) for i in range(n - 1)]
    me = bpy.data.meshes.new(name)
    made.append(me)
    me.from_pydata(verts, [], faces)
    me.update()
    me.color_attributes.new("stretch_color", "FLOAT_COLOR", "POINT")
    me.materials.append(stretch_material())
    obj = _new_object(name, me, made)
    _link(coll, obj, made)
    m = np.array(garment.matrix_world)
    corners = np.array(garment.bound_box) @ m[:3, :3].T + m[:3, 3]
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    # Clear of the garment and of an arm hanging beside it: right of it, low.
    obj.location = (hi[0] + 0.25 + 0.5 * w, lo[1], lo[2] + 0.25 * (hi[2] - lo[2]))
    _legend_text(f"{name} low", "", text, made, coll, obj, (-0.5 * w, 0.0, -text))
    _legend_text(f"{name} high", "", text, made, coll, obj, (0.5 * w, 0.0, -text))
    _legend_text(f"{name} title", "", text, made, coll, obj, (0.0, 0.0, h + text))
    for child in obj.children:
        child.rotation_euler = (np.pi / 2, 0.0, 0.0)    # upright, readable from the front
    obj["seamfit_legend_of"] = garment.get("seamfit_name", garment.name)
    return obj


def legend_of(garment):
    """The legend object of a garment (in its collection), or None."""
    name = garment.get("seamfit_name", garment.name)
    for coll in garment.users_collection:
        for obj in coll.objects:
            if obj.get("seamfit_legend_of") == name:
                return obj
    return None


def _update_legend(obj, span: float, measure: str) -> None:
    n = len(obj.data.vertices)
    t = np.repeat(np.linspace(-span, span, n // 2), 2)
    obj.data.color_attributes["stretch_color"].data.foreach_set(
        "color", stretch_colors(t, span).astype(np.float32).ravel())
    obj.data.update()
    low, high = legend_label(span)
    texts = {c.get("seamfit_name", c.name).rsplit(" ", 1)[-1]: c for c in obj.children}
    texts["low"].data.body = low
    texts["high"].data.body = high
    texts["title"].data.body = f"{STRETCH_MEASURES[measure][1]} (%)"
    obj["seamfit_span_pct"] = span


def display_outside(obj, body, edge_length_cm: float) -> None:
    """Modifiers that draw a draped garment outside its body at any mesh size: the mesh is
    split to short edges (a flat triangle of a coarse mesh cuts into a curved body between
    its vertices) and any point closer to the body than DISPLAY_CLEARANCE_M is pushed out.
    The mesh data stays the simulation's; the modifiers are in the stack, for all to see."""
    if body is None:
        return
    levels = int(max(0, np.ceil(np.log2(max(edge_length_cm / 100.0, 1e-6) / _DISPLAY_EDGE_M))))
    sub = obj.modifiers.new(DISPLAY_MODIFIERS[0], "SUBSURF")
    sub.subdivision_type = "SIMPLE"
    sub.levels = sub.render_levels = min(levels, 4)
    wrap = obj.modifiers.new(DISPLAY_MODIFIERS[1], "SHRINKWRAP")
    wrap.target = body
    wrap.wrap_method = "NEAREST_SURFACEPOINT"
    wrap.wrap_mode = "OUTSIDE"
    wrap.offset = DISPLAY_CLEARANCE_M


def _garment_with_map(coll, name: str, g, made: list, body=None, edge_length_cm: float = 0.0):
    obj = garment_mesh(name, g, made)
    _link(coll, obj, made)
    if g.stretch is not None:
        obj["seamfit_stretch"] = {}
        _legend_object(f"{name} legend", obj, coll, made)
        color_stretch(obj)
        display_outside(obj, body, edge_length_cm)
    return obj


def build_sewn(context, out, name: str, made: list) -> bpy.types.Collection:
    """A collection with the sewn-ready mesh of a pattern, flat at the panel placements."""
    coll = _new_collection(context, name, made)
    coll[PATTERN_KEY] = out.pattern_json
    coll[ROLE_KEY] = "drape"
    coll.seamfit.role = "mesh"
    obj = garment_mesh(name, out.garment, made)
    _link(coll, obj, made)
    if out.garment.stretch is not None:
        obj["seamfit_stretch"] = {}
        color_stretch(obj)
    return coll


def _store_fit(coll, fit: dict | None) -> None:
    f = coll.seamfit.fit
    f.valid = bool(fit)
    for key in ("bust", "waist", "hip"):
        has = bool(fit) and key in fit
        setattr(f, f"has_{key}", has)
        setattr(f, key, float(fit[key]) if has else 0.0)


def build_drape(context, out, name: str, body: str, made: list, body_object=None,
                edge_length_cm: float = 0.0) -> bpy.types.Collection:
    """A collection with the draped garment (``out``: compute.DrapeOutput)."""
    coll = _new_collection(context, name, made)
    coll[PATTERN_KEY] = out.pattern_json
    coll[ROLE_KEY] = "drape"
    coll.seamfit.role = "drape"
    coll.seamfit.body = body
    _garment_with_map(coll, f"{name} garment", out.garment, made, body_object, edge_length_cm)
    _store_fit(coll, out.fit)
    return coll


def build_graded(context, out, name: str, base_collection: str, body: str, made: list, body_object=None,
                 edge_length_cm: float = 0.0, parent=None) -> bpy.types.Collection:
    """A collection with the graded pattern's panel curves and stitches, and the garment
    sewn from it draped on the target body (``out``: compute.GradeOutput)."""
    pattern = compute.pattern_from_json(out.pattern_json, source="graded pattern")
    coll = build_pattern(context, pattern, name, role="graded", body=body, made=made, parent=parent)
    coll["seamfit_base"] = base_collection
    if out.garment is not None:
        _garment_with_map(coll, f"{name} garment", out.garment, made, body_object, edge_length_cm)
    _store_fit(coll, out.fit)
    coll.seamfit.objective = float(out.objective)
    coll.seamfit.iterations = int(out.iterations)
    coll.seamfit.method = out.method
    for w in getattr(out, "warnings", None) or []:
        it = coll.seamfit.warnings.add()
        it.name = w
    return coll


SIZE_RUN_KEY = "seamfit_size_run"  # collection: the sizes of a graded size run (JSON)


def chosen_collection(name: str, is_kind, kind: str, none_yet: str):
    """The collection called ``name``, which must be a ``kind`` (is_kind(c)); with no name,
    the newest ``kind`` in the file (AddonError ``none_yet`` when there is none)."""
    if name:
        coll = bpy.data.collections.get(name)
        if coll is None or not is_kind(coll):
            raise compute.AddonError(f"no {kind} named {name!r}")
        return coll
    found = [c for c in bpy.data.collections if is_kind(c)]
    if not found:
        raise compute.AddonError(none_yet)
    return found[-1]


def build_size_run(context, out, name: str, base_collection: str, made: list, body_objects: dict,
                   edge_length_cm: float = 0.0) -> bpy.types.Collection:
    """A collection holding one graded collection per size of a size run (``out``:
    size_run_job.SizeRunOutput), each as Adjust Pattern makes it."""
    coll = _new_collection(context, name, made)
    coll.seamfit.role = "size_run"
    coll[SIZE_RUN_KEY] = json.dumps({"labels": out.labels, "base_index": out.base_index, "base": base_collection})
    for k, label in enumerate(out.labels):
        if k != out.base_index:
            build_graded(context, out.sizes[label], f"{label} {base_collection}", base_collection, body=label,
                         made=made, body_object=body_objects.get(label), edge_length_cm=edge_length_cm,
                         parent=coll)
    return coll


def size_run_patterns(coll) -> tuple[list, list[str], int]:
    """(patterns in size order as the scene shows them, size names, index of the base) of
    a size run's collection; the base pattern is read from its own collection."""
    if SIZE_RUN_KEY not in coll:
        raise compute.AddonError(f"collection {coll.name!r} holds no size run")
    run = json.loads(coll[SIZE_RUN_KEY])
    base = bpy.data.collections.get(run["base"])
    if base is None:
        raise compute.AddonError(f"{coll.name!r}: its base pattern {run['base']!r} is no longer in the scene")
    by_body = {c.seamfit.body: c for c in coll.children if is_pattern_collection(c)}
    patterns = []
    for k, label in enumerate(run["labels"]):
        if k == run["base_index"]:
            patterns.append(pattern_from_collection(base))
        elif label in by_body:
            patterns.append(pattern_from_collection(by_body[label]))
        else:
            raise compute.AddonError(f"{coll.name!r}: the collection of size {label!r} was deleted")
    return patterns, list(run["labels"]), int(run["base_index"])


# ---------------------------------------------------------------------------
# Compare view: base and graded outlines flat, as pattern makers check a grading

COMPARE_LAYOUTS = {
    "SIDE_BY_SIDE": ("Side by side", "Each graded panel beside its base panel"),
    "OVERLAY": ("Overlaid", "Each graded panel over its base panel, aligned at the middle of the top edge "
                            "(seamfit's grading nest)"),
}
_COMPARE_GAP_M = 0.06


def _flat_copy(pattern, offsets: dict):
    """``pattern`` with every panel placed flat on the floor, its anchor at offsets[name]."""
    import copy
    flat = copy.deepcopy(pattern)
    for pn in flat.panels:
        o = pn.outline_cm
        anchor = np.array([0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()])
        pn.placement.rotation = np.eye(3)
        ox, oy, oz = offsets[pn.name]
        pn.placement.translation_m = np.array([ox - 0.01 * anchor[0], oy - 0.01 * anchor[1], oz])
    return flat


def compare_layout(base, graded, layout: str, origin=(0.0, 0.0)) -> tuple[dict, dict, tuple]:
    """Anchor positions (m, on the floor) of each panel of the base and graded patterns:
    one slot per panel name, rows left to right, tallest panels first; returns
    (base offsets, graded offsets, (x0, y0, x1, y1) of the sheet)."""
    def extent(pn):
        o = 0.01 * pn.outline_cm
        ax, ay = 0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()
        return o[:, 0].min() - ax, o[:, 0].max() - ax, o[:, 1].min() - ay     # left, right, bottom (<= 0)

    gp = {pn.name: pn for pn in graded.panels}
    slots = []
    for pn in base.panels:
        l0, r0, b0 = extent(pn)
        l1, r1, b1 = extent(gp[pn.name]) if pn.name in gp else (l0, r0, b0)
        if layout == "OVERLAY":
            slots.append((pn.name, min(l0, l1), max(r0, r1), min(b0, b1), 0.0))
        else:
            shift = (r0 - l1) + _COMPARE_GAP_M / 2      # the graded copy right of the base one
            slots.append((pn.name, l0, shift + r1, min(b0, b1), shift))
    slots.sort(key=lambda s: s[3])
    area = sum((r - l) * -b for _, l, r, b, _ in slots)
    row_width = max(max(r - l for _, l, r, _, _ in slots), 1.5 * float(np.sqrt(area)))
    x, y, row_h, width = 0.0, 0.0, 0.0, 0.0
    base_at, graded_at = {}, {}
    for name, left, right, bottom, shift in slots:
        w, h = right - left, -bottom
        if x > 0.0 and x + w > row_width:
            x, y, row_h = 0.0, y - row_h - 2 * _COMPARE_GAP_M, 0.0
        ax = origin[0] + x - left
        base_at[name] = (ax, origin[1] + y, 0.0)
        graded_at[name] = (ax + shift, origin[1] + y, 0.001)     # drawn over the base where they overlap
        x += w + _COMPARE_GAP_M
        row_h = max(row_h, h)
        width = max(width, x - _COMPARE_GAP_M)
    return base_at, graded_at, (origin[0], origin[1] + y - row_h, origin[0] + width, origin[1])


def build_compare(context, base_pattern, graded_pattern, name: str, layout: str, made: list,
                  origin=(0.0, 0.0), labels=("base", "graded")) -> bpy.types.Collection:
    """A collection with flat copies of the base and graded patterns (each a pattern
    collection, so the overlay labels their corners and stitch lengths)."""
    base_at, graded_at, sheet = compare_layout(base_pattern, graded_pattern, layout, origin)
    coll = _new_collection(context, name, made)
    coll.seamfit.role = "compare"
    coll["seamfit_sheet"] = list(sheet)
    for pattern, at, label, colour in ((base_pattern, base_at, labels[0], (0.05, 0.05, 0.05, 1.0)),
                                       (graded_pattern, graded_at, labels[1], (0.84, 0.37, 0.0, 1.0))):
        flat = _flat_copy(pattern, {n: at.get(n, (0.0, 0.0, 0.0)) for n in (p.name for p in pattern.panels)})
        child = build_pattern(context, flat, f"{name} {label}", role="compare", parent=coll, made=made,
                              with_stitches=False)
        for obj in child.objects:
            obj.color = colour
            obj.data.fill_mode = "NONE"     # outlines, so both copies show where they overlap
            obj.data.bevel_depth = 0.0015   # and they render
    return coll
