# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators for patterns and bodies: import, export, body checks, cache."""
from __future__ import annotations

import os
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import compute, dxf_io, presets, scene_io
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
    """float64 of the shortest decimal that gives back each float32 (numpy's str: its repr
    is 'np.float32(0.1)' from numpy 2 on, as in Blender 5.1 and later)."""
    return np.array([float(str(x)) for x in np.asarray(a, dtype=np.float32)], dtype=np.float64)


def pattern_name(pattern, filepath: str) -> str:
    parts = [p for p in (pattern.garment_id, pattern.body_id) if p]
    return " ".join(parts) if parts else Path(filepath).stem


_size_items: list = []      # Blender needs the enum's strings kept alive
ONE_SIZE = "ONE_SIZE"       # the size enum of a file that holds one size


def _file_sizes(self, context):
    """The sizes of the chosen DXF, its sample size first (the default)."""
    labels, sample = dxf_io.file_sizes(self.filepath) if dxf_io.is_dxf(self.filepath) else ([], None)
    if sample in labels:
        labels = [sample] + [lab for lab in labels if lab != sample]
    _size_items[:] = [(lab, lab + (" (sample size)" if lab == sample else ""), f"Import size {lab}")
                      for lab in labels] or [(ONE_SIZE, "One size", "The file holds one size")]
    return _size_items


class SEAMFIT_OT_import_pattern(bpy.types.Operator, ImportHelper):
    """Import a sewing pattern (sewpat-1, GarmentCode JSON or DXF-AAMA/ASTM) as flat panel curves"""
    bl_idname = "seamfit.import_pattern"
    bl_label = "Import Sewing Pattern"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json;*.dxf", options={"HIDDEN"})
    size: EnumProperty(name="Size", items=_file_sizes,
                       description="Of a multi-size DXF, the size to import (its pieces' Size text)")

    def check(self, context):
        return True         # the size list follows the file picked

    def draw(self, context):
        if dxf_io.is_dxf(self.filepath) and self.size != ONE_SIZE:
            self.layout.prop(self, "size")

    def execute(self, context):
        size = None if self.size == ONE_SIZE else self.size
        try:
            proposals, notes = [], []
            if dxf_io.is_dxf(self.filepath):
                pattern, proposals = dxf_io.read(self.filepath, size)
                notes = dxf_io.notes(pattern)
            else:
                pattern = compute.load_pattern(self.filepath)
            warnings = compute.check_pattern(pattern)
            name = pattern_name(pattern, self.filepath) + (f" {size}" if size else "")
            coll = scene_io.build_pattern(context, pattern, name, source=self.filepath,
                                          body=pattern.body_id or "")
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        s = context.scene.seamfit
        s.pattern = coll
        coll.seamfit.size = size or ""
        _store_proposals(coll, proposals)
        # The preset for the garment's kind, as `seamfit grade --preset auto` picks it;
        # strengths set by hand (Custom) are left alone.
        kind = presets.for_garment(pattern.garment_type)
        if kind is not None and s.strength_preset != "CUSTOM":
            s.strength_preset = kind
        for w in [*notes, *warnings]:
            self.report({"WARNING"}, w)
        more = f", {len(proposals)} proposed: accept them in the Patterns panel" if proposals else ""
        self.report({"INFO"}, f"Imported {coll.name}: {len(pattern.panels)} panels, "
                              f"{len(pattern.stitches)} stitches{more}")
        return {"FINISHED"}


def _store_proposals(coll, proposals: list[dict]) -> None:
    import json
    info = coll.seamfit
    info.proposals.clear()
    for entry in proposals:
        it = info.proposals.add()
        it.entry = json.dumps(entry, sort_keys=True)
        it.name = f"{entry['a']['panel']} - {entry['b']['panel']}"
        it.panel_a, it.panel_b = entry["a"]["panel"], entry["b"]["panel"]
        it.length_a_cm, it.length_b_cm = entry.get("length_a_cm", 0.0), entry.get("length_b_cm", 0.0)
        it.why = "; ".join([entry.get("why", ""), *entry.get("notch_warnings", [])]).strip("; ")


class PatternOperator:
    """An operator on one pattern: the collection named ``collection``, or the active pattern."""
    bl_options = {"REGISTER", "UNDO"}
    no_pattern = "no pattern"   # the start of the message when there is none

    collection: StringProperty(name="Pattern", description="Name of the pattern collection (the active "
                               "pattern when empty)")

    def pattern_collection(self, context):
        if self.collection:
            coll = bpy.data.collections.get(self.collection)
            if coll is None:
                raise compute.AddonError(f"no collection named {self.collection!r}")
            return coll
        coll = context.scene.seamfit.pattern
        if coll is None:
            raise compute.AddonError(f"{self.no_pattern}: import one or pick it in the Patterns panel")
        return coll


class SEAMFIT_OT_confirm_stitches(PatternOperator, bpy.types.Operator):
    """Sew the accepted proposed stitches into the pattern (the DXF file is never changed)"""
    bl_idname = "seamfit.confirm_stitches"
    bl_label = "Confirm Stitches"

    def execute(self, context):
        import json
        try:
            coll = self.pattern_collection(context)
            chosen = [json.loads(p.entry) for p in coll.seamfit.proposals if p.accept]
            if not chosen:
                raise compute.AddonError(f"{coll.name}: no proposed stitch accepted; tick the ones to sew")
            for entry in chosen:
                entry["confirmed"] = True
            pattern = dxf_io.apply_choices(scene_io.pattern_from_collection(coll), chosen)
            scene_io.set_stitches(coll, pattern)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        coll.seamfit.proposals.clear()
        self.report({"INFO"}, f"{coll.name}: {len(pattern.stitches)} stitches confirmed")
        return {"FINISHED"}


_FORMATS = {
    "SEWPAT": ("sewpat-1 (.json)", "seamfit's pattern format: outlines, curves, stitches, placement"),
    "SVG": ("SVG (.svg)", "A drawing of the panels in centimetres"),
    "DXF_AAMA": ("DXF-AAMA (.aama.dxf)", "The AAMA pattern exchange DXF (seams sidecar beside it)"),
    "DXF_ASTM": ("DXF-ASTM (.astm.dxf)", "ASTM D6673 DXF (seams sidecar beside it)"),
}


class SEAMFIT_OT_export_pattern(PatternOperator, bpy.types.Operator, ExportHelper):
    """Export a pattern of the scene (as its curves show it now) to sewpat-1 JSON, SVG or
    DXF-AAMA/ASTM"""
    bl_idname = "seamfit.export_pattern"
    bl_label = "Export Sewing Pattern"
    bl_options = {"REGISTER"}
    no_pattern = "no pattern to export"

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json;*.svg;*.dxf", options={"HIDDEN"})
    format: EnumProperty(name="Format", items=[(k, *v) for k, v in _FORMATS.items()], default="SEWPAT")
    with_base: BoolProperty(name="Include base pattern", default=True,
                            description="For a graded pattern, draw the base pattern under it in the SVG")
    use_allowance: BoolProperty(name="Seam allowance", default=False,
                                description="DXF: draw the cut line this far outside the seam line on every edge "
                                            "without an allowance of its own (seamfit convert --seam-allowance)")
    allowance_cm: FloatProperty(name="Width (cm)", default=1.0, min=0.0, soft_max=5.0, precision=2,
                                description="Seam allowance in cm")
    corners: EnumProperty(name="Corners", items=[(c, f"{c.capitalize()}d", f"Seam allowance corners {c}d "
                                                  f"(seamfit convert --corners {c})")
                                                 for c in dxf_io.corner_styles()],
                          description="How the seam allowance turns a corner")

    def check(self, context):
        # Keep the file extension in step with the chosen format.
        ext = dxf_io.EXPORT_FORMATS[self.format][0]
        changed = self.filename_ext != ext
        self.filename_ext = ext
        if self.filepath:
            old = dxf_io.extension_of(self.filepath)
            if old and old != ext:
                self.filepath = self.filepath[: -len(old)] + ext
                changed = True
        return changed

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "format")
        if self.format == "SVG":
            layout.prop(self, "with_base")
        elif self.format.startswith("DXF"):
            layout.prop(self, "use_allowance")
            col = layout.column()
            col.enabled = self.use_allowance
            col.prop(self, "allowance_cm")
            col.prop(self, "corners")

    def execute(self, context):
        try:
            coll = self.pattern_collection(context)
            pattern = scene_io.pattern_from_collection(coll)
            written = [self.filepath]
            if self.format == "SVG":
                patterns, labels = [pattern], [coll.name]
                base = coll.get("seamfit_base")
                if self.with_base and base and base in bpy.data.collections:
                    patterns.insert(0, scene_io.pattern_from_collection(bpy.data.collections[base]))
                    labels.insert(0, base)
                compute.save_svg(patterns, self.filepath, labels=labels)
            elif self.format.startswith("DXF"):
                base = bpy.data.collections.get(coll.get("seamfit_base", ""))
                written = dxf_io.export_dxf(pattern, self.filepath, dxf_io.EXPORT_FORMATS[self.format][1],
                                            allowance_cm=float(self.allowance_cm) if self.use_allowance else None,
                                            corners=self.corners,
                                            protect=(base.seamfit.source,) if base is not None else ())
            else:
                compute.save_pattern(pattern, self.filepath)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {coll.name} to {', '.join(written)}")
        return {"FINISHED"}


class SEAMFIT_OT_apply_edits(PatternOperator, bpy.types.Operator):
    """Read the edited panel curves back into the pattern, check it as a file is checked,
    and keep it in the scene (the pattern file is never changed)"""
    bl_idname = "seamfit.apply_edits"
    bl_label = "Apply Curve Edits"

    def execute(self, context):
        try:
            coll = self.pattern_collection(context)
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
            coll = scene_io.chosen_collection(self.collection, lambda c: c.seamfit.role == "graded", "graded pattern",
                                              "no graded pattern to compare: run Adjust Pattern first")
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
    self.layout.operator(SEAMFIT_OT_import_pattern.bl_idname, text="Sewing Pattern (.json, .dxf)")


def menu_export(self, context):
    self.layout.operator(SEAMFIT_OT_export_pattern.bl_idname, text="Sewing Pattern (.json, .svg, .dxf)")


CLASSES = (SEAMFIT_OT_import_pattern, SEAMFIT_OT_confirm_stitches, SEAMFIT_OT_export_pattern, SEAMFIT_OT_apply_edits,
           SEAMFIT_OT_check_bodies, SEAMFIT_OT_compare, SEAMFIT_OT_clear_cache)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    bpy.types.TOPBAR_MT_file_import.append(menu_import)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(menu_import)
    _unregister_classes()
