# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators for patterns and bodies: import, export, body checks, cache."""
from __future__ import annotations

import os
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import compute, presets, scene_io
from .cache import CACHE


def capture_body(obj, depsgraph) -> compute.BodyInput:
    """The body as it shows in the scene (modifiers applied), in world metres."""
    if obj is None or obj.type != "MESH":
        raise compute.AddonError("pick a mesh object as the body")
    ev = obj.evaluated_get(depsgraph)
    me = ev.to_mesh()
    try:
        me.calc_loop_triangles()
        v = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", v)
        t = np.empty(len(me.loop_triangles) * 3, dtype=np.int32)
        me.loop_triangles.foreach_get("vertices", t)
    finally:
        ev.to_mesh_clear()
    if len(t) == 0:
        raise compute.AddonError(f"body {obj.name!r} has no faces")
    # Blender keeps float32; the shortest decimal of each float32 is the number the mesh file
    # held (OBJ/PLY bodies carry at most 7 digits), so seamfit gets the very body the command
    # line reads from that file, not one perturbed by 1e-7.
    v = _decimal_f32(v).reshape(-1, 3)
    m = _decimal_f32(np.array(obj.matrix_world, dtype=np.float32).ravel()).reshape(4, 4)
    if not np.array_equal(m, np.eye(4)):
        v = v @ m[:3, :3].T + m[:3, 3]
    return compute.BodyInput(obj.name, v, t.reshape(-1, 3))


def _decimal_f32(a) -> np.ndarray:
    """float64 of the shortest decimal that gives back each float32 (numpy's repr)."""
    return np.array([float(repr(x)) for x in np.asarray(a, dtype=np.float32)], dtype=np.float64)


def pattern_name(pattern, filepath: str) -> str:
    parts = [p for p in (pattern.garment_id, pattern.body_id) if p]
    return " ".join(parts) if parts else Path(filepath).stem


class SEAMFIT_OT_import_pattern(bpy.types.Operator, ImportHelper):
    """Import a sewing pattern (sewpat-1 or GarmentCode JSON) as flat panel curves"""
    bl_idname = "seamfit.import_pattern"
    bl_label = "Import Sewing Pattern"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        try:
            pattern = compute.load_pattern(self.filepath)
            warnings = compute.check_pattern(pattern)
            name = pattern_name(pattern, self.filepath)
            coll = scene_io.build_pattern(context, pattern, name, source=self.filepath,
                                          body=pattern.body_id or "")
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        s = context.scene.seamfit
        s.pattern = coll
        # The preset for the garment's kind, as `seamfit grade --preset auto` picks it;
        # strengths set by hand (Custom) are left alone.
        kind = presets.for_garment(pattern.garment_type)
        if kind is not None and s.strength_preset != "CUSTOM":
            s.strength_preset = kind
        for w in warnings:
            self.report({"WARNING"}, w)
        self.report({"INFO"}, f"Imported {coll.name}: {len(pattern.panels)} panels, "
                              f"{len(pattern.stitches)} stitches")
        return {"FINISHED"}


class SEAMFIT_OT_export_pattern(bpy.types.Operator, ExportHelper):
    """Export a pattern of the scene (as its curves show it now) to sewpat-1 JSON or SVG"""
    bl_idname = "seamfit.export_pattern"
    bl_label = "Export Sewing Pattern"
    bl_options = {"REGISTER"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json;*.svg", options={"HIDDEN"})
    collection: StringProperty(name="Pattern", description="Name of the pattern collection (the active "
                               "pattern when empty)")
    format: EnumProperty(name="Format", items=[
        ("SEWPAT", "sewpat-1 (.json)", "seamfit's pattern format: outlines, curves, stitches, placement"),
        ("SVG", "SVG (.svg)", "A drawing of the panels in centimetres"),
    ], default="SEWPAT")
    with_base: BoolProperty(name="Include base pattern", default=True,
                            description="For a graded pattern, draw the base pattern under it in the SVG")

    def check(self, context):
        # Keep the file extension in step with the chosen format.
        ext = ".svg" if self.format == "SVG" else ".json"
        changed = self.filename_ext != ext
        self.filename_ext = ext
        if self.filepath:
            root, old = os.path.splitext(self.filepath)
            if old.lower() in (".json", ".svg") and old.lower() != ext:
                self.filepath = root + ext
                changed = True
        return changed

    def _collection(self, context):
        if self.collection:
            coll = bpy.data.collections.get(self.collection)
            if coll is None:
                raise compute.AddonError(f"no collection named {self.collection!r}")
            return coll
        coll = context.scene.seamfit.pattern
        if coll is None:
            raise compute.AddonError("no pattern to export: import one or pick it in the Patterns panel")
        return coll

    def execute(self, context):
        try:
            coll = self._collection(context)
            pattern = scene_io.pattern_from_collection(coll)
            if self.format == "SVG":
                patterns, labels = [pattern], [coll.name]
                base = coll.get("seamfit_base")
                if self.with_base and base and base in bpy.data.collections:
                    patterns.insert(0, scene_io.pattern_from_collection(bpy.data.collections[base]))
                    labels.insert(0, base)
                compute.save_svg(patterns, self.filepath, labels=labels)
            else:
                compute.save_pattern(pattern, self.filepath)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {coll.name} to {self.filepath}")
        return {"FINISHED"}


class SEAMFIT_OT_apply_edits(bpy.types.Operator):
    """Read the edited panel curves back into the pattern, check it as a file is checked,
    and keep it in the scene (the pattern file is never changed)"""
    bl_idname = "seamfit.apply_edits"
    bl_label = "Apply Curve Edits"
    bl_options = {"REGISTER", "UNDO"}

    collection: StringProperty(name="Pattern", description="Name of the pattern collection (the active "
                               "pattern when empty)")

    def execute(self, context):
        try:
            coll = _pattern_collection(context, self.collection)
            edited, warnings = scene_io.apply_edits(coll)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        for w in warnings:
            self.report({"WARNING"}, w)
        if not edited:
            self.report({"INFO"}, f"{coll.name}: no curve was edited")
        else:
            self.report({"INFO"}, f"{coll.name}: applied the edits of {len(edited)} panel(s) "
                                  f"({', '.join(edited)})")
        return {"FINISHED"}


def _pattern_collection(context, name: str):
    """The pattern collection called ``name``, or the active pattern."""
    if name:
        coll = bpy.data.collections.get(name)
        if coll is None:
            raise compute.AddonError(f"no collection named {name!r}")
        return coll
    coll = context.scene.seamfit.pattern
    if coll is None:
        raise compute.AddonError("no pattern: import one or pick it in the Patterns panel")
    return coll


class SEAMFIT_OT_check_bodies(bpy.types.Operator):
    """Check the base and target bodies (units, up axis, facing, holes and pose first, then
    the mesh) and measure their height and girths"""
    bl_idname = "seamfit.check_bodies"
    bl_label = "Check Bodies"
    bl_options = {"REGISTER", "UNDO"}     # the reports are stored in the scene

    def execute(self, context):
        s = context.scene.seamfit
        if s.base_body is None and s.target_body is None:
            self.report({"ERROR"}, "pick a base and a target body first")
            return {"CANCELLED"}
        depsgraph = context.evaluated_depsgraph_get()
        try:
            base = capture_body(s.base_body, depsgraph) if s.base_body is not None else None
        except compute.user_errors():
            base = None                       # reported as the base body's own problem below
        failed, lines = False, []
        for obj, rep, role in ((s.base_body, s.base_report, "base"), (s.target_body, s.target_report, "target")):
            rep.checked = False
            if obj is None:
                continue
            ok, message = check_body_into(rep, obj, depsgraph, base if role == "target" else False)
            if not ok:
                failed = True
                self.report({"ERROR"}, f"{role} body {obj.name!r}: {message}")
            else:
                lines.append(f"{role} {obj.name}: {_summary(rep)}")
        if failed:
            return {"CANCELLED"}
        self.report({"INFO"}, "Bodies checked: " + "; ".join(lines))
        return {"FINISHED"}


def _summary(rep) -> str:
    text = f"{rep.height:.1f} cm tall"
    if rep.registered:
        text += (f", registered onto the base body's mesh ({rep.registration_mean_mm:.1f} mm mean, "
                 f"{rep.registration_max_mm:.1f} mm max)")
    elif rep.registering:
        text += ", another mesh than the base body: registered when grading"
    return text


def check_body_into(rep, obj, depsgraph, base=False) -> tuple[bool, str]:
    """Fill a body report; returns (ok, message). ``base`` is the captured base body for a
    target (None: no base body, compared with the sample bodies' mesh), False for the base
    itself. seamfit's checks before any fitting come first: a body in other units, lying
    on its back (Y up, as Blender's OBJ importer lays a Z-up file down) or in another pose
    gets the one-line reason and the fix."""
    from . import bodies
    try:
        body = capture_body(obj, depsgraph)
        registering = base is not False and compute.needs_registration(base, body)
        refused = compute.quick_check(body, registering)
        report = None if refused else compute.body_report(body)
    except compute.user_errors() as exc:
        rep.checked, rep.ok, rep.message, rep.key = True, False, str(exc), ""
        return False, str(exc)
    rep.checked = True
    rep.key = body.key
    rep.registering, rep.registered = registering, False
    if refused:
        rep.ok, rep.message = False, refused
        return False, refused
    rep.ok = not report["errors"]
    msgs = report["errors"] or report["warnings"]
    rep.message = "; ".join(msgs) if msgs else "valid"
    m = report["measurements"]
    rep.height = m.get("height", 0.0)
    rep.bust = m.get("bust", 0.0)
    rep.waist = m.get("waist", 0.0)
    rep.hip = m.get("hip", 0.0)
    if rep.ok and registering:
        reg = compute.registration_done(base, body) if base else None
        if reg is not None:
            bodies.show_registration(rep, reg)
        if rep.message == "valid":
            rep.message = (f"another mesh than the base body ({len(body.vertices)} vertices): grading registers "
                           "the base body's mesh onto it (Register Target shows how close it comes)")
    return rep.ok, rep.message


class SEAMFIT_OT_compare(bpy.types.Operator):
    """Lay a graded pattern and its base pattern out flat beside the bodies, panel by panel,
    to compare their outlines (replaces the previous compare view of that grading)"""
    bl_idname = "seamfit.compare"
    bl_label = "Compare with Base"
    bl_options = {"REGISTER", "UNDO"}

    collection: StringProperty(name="Graded pattern", description="Name of the graded collection (the newest "
                               "grading when empty)")
    layout: EnumProperty(name="Layout", items=[(k, *v) for k, v in scene_io.COMPARE_LAYOUTS.items()],
                         default="SIDE_BY_SIDE")

    def execute(self, context):
        try:
            coll = self._graded(context)
            base_name = coll.get("seamfit_base", "")
            base_coll = bpy.data.collections.get(base_name)
            if base_coll is None:
                raise compute.AddonError(f"{coll.name!r}: its base pattern {base_name!r} is no longer in the scene")
            base = scene_io.pattern_from_collection(base_coll)
            graded = scene_io.pattern_from_collection(coll)
            key = compute.digest("compare", compute.pattern_to_json(base), compute.pattern_to_json(graded),
                                 self.layout)
            slot = scene_io.slot_name("compare", coll.name)
            same = scene_io.reusable(slot, key)
            origin = (_beside_bodies(context), 0.0)
            labels = (f"base ({base_coll.seamfit.body or base_coll.name})", f"graded ({coll.seamfit.body})")
            out = same or scene_io.place_result(
                context, slot, key, f"{coll.name} compare",
                lambda c, n, made: scene_io.build_compare(c, base, graded, n, self.layout, made, origin, labels))
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Compare view of {coll.name} in {out.name!r} (seen from above: numpad 7)")
        return {"FINISHED"}

    def _graded(self, context):
        if self.collection:
            coll = bpy.data.collections.get(self.collection)
            if coll is None or coll.seamfit.role != "graded":
                raise compute.AddonError(f"no graded pattern named {self.collection!r}")
            return coll
        graded = [c for c in bpy.data.collections if c.seamfit.role == "graded"]
        if not graded:
            raise compute.AddonError("no graded pattern to compare: run Adjust Pattern first")
        return graded[-1]


def _beside_bodies(context) -> float:
    """x (m) just right of the bodies and garments of the scene, where the flat view goes."""
    right = 0.5
    for obj in context.scene.objects:
        if obj.type == "MESH":
            m = np.array(obj.matrix_world)
            corners = np.array(obj.bound_box) @ m[:3, :3].T + m[:3, 3]
            right = max(right, float(corners[:, 0].max()))
    return right + 0.3


class SEAMFIT_OT_clear_cache(bpy.types.Operator):
    """Forget cached meshes, distance fields, drapes and gradings, in memory and on disk"""
    bl_idname = "seamfit.clear_cache"
    bl_label = "Clear Cache"

    def execute(self, context):
        from . import cache
        CACHE.clear()
        n, size = cache.disk_usage()
        cache.clear_disk()
        self.report({"INFO"}, f"Cleared the cache: {n} files, {size / 2**20:.0f} MB on disk")
        return {"FINISHED"}


def menu_import(self, context):
    self.layout.operator(SEAMFIT_OT_import_pattern.bl_idname, text="Sewing Pattern (.json)")


def menu_export(self, context):
    self.layout.operator(SEAMFIT_OT_export_pattern.bl_idname, text="Sewing Pattern (.json, .svg)")


CLASSES = (SEAMFIT_OT_import_pattern, SEAMFIT_OT_export_pattern, SEAMFIT_OT_apply_edits, SEAMFIT_OT_check_bodies,
           SEAMFIT_OT_compare, SEAMFIT_OT_clear_cache)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_import.append(menu_import)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(menu_import)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
