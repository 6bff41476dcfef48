# SPDX-License-Identifier: GPL-3.0-or-later
"""The seamfit tab of the 3D viewport's sidebar: Patterns, Bodies, Costs, Run."""
from __future__ import annotations

import bpy

from . import compute, jobs, methods, presets, scene_io
from .cache import CACHE


class SEAMFIT_UL_panels(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.label(text=item.name, icon="MESH_PLANE")
        row.label(text=f"{item.n_vertices} pts, {item.n_corners} corners")
        row.label(text=f"{item.area_cm2:.0f} cm²")


class SEAMFIT_UL_stitches(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.label(text=f"{item.panel_a} – {item.panel_b}", icon="AUTOMERGE_ON" if not item.gathered else "MOD_CLOTH")
        row.label(text=f"{item.length_a_cm:.1f} / {item.length_b_cm:.1f} cm")


class SEAMFIT_UL_proposals(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "accept", text="")
        row.label(text=f"{item.panel_a} – {item.panel_b}")
        row.label(text=f"{item.length_a_cm:.1f} / {item.length_b_cm:.1f} cm")


class _SeamfitPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "seamfit"


class SEAMFIT_PT_patterns(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Patterns"

    def draw(self, context):
        s = context.scene.seamfit
        layout = self.layout
        layout.operator("seamfit.import_pattern", icon="IMPORT")
        layout.prop(s, "pattern")
        row = layout.row(align=True)
        row.prop(s, "edge_length_cm")
        row.operator("seamfit.build_mesh", text="", icon="MOD_TRIANGULATE")
        coll = s.pattern
        if coll is None:
            layout.label(text="No pattern: import a sewpat-1, GarmentCode or DXF file", icon="INFO")
            return
        info = coll.seamfit
        if info.source:
            layout.label(text=bpy.path.basename(info.source) + (f", size {info.size}" if info.size else ""),
                         icon="FILE")
        layout.label(text=f"Panels ({len(info.panels)})")
        layout.template_list("SEAMFIT_UL_panels", "", info, "panels", info, "active_panel", rows=3)
        layout.label(text=f"Stitches ({len(info.stitches)}): length of side A / side B")
        layout.template_list("SEAMFIT_UL_stitches", "", info, "stitches", info, "active_stitch", rows=3)
        if len(info.proposals):
            _draw_proposals(layout.box(), coll)
        layout.prop(s, "show_overlay")
        layout.operator("seamfit.apply_edits", icon="CURVE_BEZCURVE").collection = coll.name
        row = layout.row(align=True)
        op = row.operator("seamfit.export_pattern", text="Export sewpat-1", icon="EXPORT")
        op.format, op.collection = "SEWPAT", coll.name
        op = row.operator("seamfit.export_pattern", text="Export SVG")
        op.format, op.collection = "SVG", coll.name
        row = layout.row(align=True)
        for fmt, text in (("DXF_AAMA", "Export DXF-AAMA"), ("DXF_ASTM", "Export DXF-ASTM")):
            op = row.operator("seamfit.export_pattern", text=text, icon="EXPORT" if fmt == "DXF_AAMA" else "NONE")
            op.format, op.collection = fmt, coll.name


def _draw_proposals(box, coll):
    """The stitches seamfit proposes for a DXF pattern, to accept and confirm."""
    info = coll.seamfit
    box.label(text=f"Proposed stitches ({len(info.proposals)}): tick the ones to sew", icon="QUESTION")
    box.template_list("SEAMFIT_UL_proposals", "", info, "proposals", info, "active_proposal", rows=3)
    if 0 <= info.active_proposal < len(info.proposals):
        box.label(text=info.proposals[info.active_proposal].why, icon="INFO")
    box.operator("seamfit.confirm_stitches", icon="CHECKMARK").collection = coll.name


def _draw_body(layout, s, prop, rep):
    box = layout.box()
    box.prop(s, prop)
    if getattr(s, prop) is None or not rep.checked:
        return
    if not rep.ok:
        box.label(text=rep.message, icon="ERROR")
        return
    col = box.column(align=True)
    col.label(text=f"Height {rep.height:.1f} cm", icon="CHECKMARK")
    col.label(text=f"Bust {rep.bust:.1f}   Waist {rep.waist:.1f}   Hip {rep.hip:.1f} cm")
    if rep.registered:
        col.label(text=f"Registered: {rep.registration_mean_mm:.1f} mm mean, {rep.registration_max_mm:.1f} mm max "
                       "from its surface", icon="MOD_SHRINKWRAP")
    if rep.message and rep.message != "valid":
        col.label(text=rep.message, icon="INFO")


class SEAMFIT_PT_bodies(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Bodies"

    def draw(self, context):
        s = context.scene.seamfit
        _draw_body(self.layout, s, "base_body", s.base_report)
        _draw_body(self.layout, s, "target_body", s.target_report)
        row = self.layout.row(align=True)
        row.operator("seamfit.check_bodies", icon="VIEWZOOM")
        if s.target_report.checked and s.target_report.registering:
            row.operator("seamfit.register_target", icon="MOD_SHRINKWRAP")


class SEAMFIT_PT_measure(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Body from Measurements"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from . import bodies, props
        m = context.scene.seamfit.measure
        layout = self.layout
        layout.row().prop(m, "units", expand=True)
        row = layout.row(align=True)
        row.operator("seamfit.load_size_chart", text="Size Chart", icon="FILE")
        row.prop(m, "size", text="")
        if m.chart:
            layout.label(text=bpy.path.basename(m.chart), icon="PRESET")
        layout.prop(m, "gender")
        layout.prop(m, "body_name")
        col = layout.column(align=True)
        for key in props.MEASUREMENTS:
            col.prop(m, props.field_name(key))
        layout.label(text=f"In {props.UNITS[m.units]}; 0: not measured (inferred)", icon="INFO")
        layout.operator("seamfit.body_from_measurements", icon="OUTLINER_OB_ARMATURE")
        obj = context.active_object
        if bodies.is_made_body(obj):
            _draw_made_body(layout.box(), obj, props.cm_per_unit(m.units), props.UNITS[m.units])


def _draw_made_body(box, obj, per_unit: float, unit: str):
    """A made body's measurements: requested and achieved (inferred ones marked)."""
    from . import bodies
    box.label(text=f"{obj.name}: requested / achieved ({unit})", icon="OBJECT_DATA")
    requested, achieved = obj[bodies.REQUESTED], obj[bodies.ACHIEVED]
    col = box.column(align=True)
    for key in achieved.keys():
        want = f"{requested[key] / per_unit:.1f}" if key in requested else "inferred"
        col.label(text=f"{key.replace('_', ' ').capitalize()}: {want} / {achieved[key] / per_unit:.1f}")
    if obj.get(bodies.PROBLEMS):
        box.label(text=obj[bodies.PROBLEMS], icon="ERROR")


class SEAMFIT_PT_costs(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Costs"

    def draw(self, context):
        s = context.scene.seamfit
        layout = self.layout
        layout.prop(s, "method")
        layout.prop(s, "strength_preset")
        col = layout.column(align=True)
        for key in presets.STRENGTH_KEYS:
            col.prop(s, f"strength_{key}")


class SEAMFIT_PT_simulation(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Simulation"
    bl_parent_id = "SEAMFIT_PT_costs"

    def draw(self, context):
        s = context.scene.seamfit
        col = self.layout.column(align=True)
        col.label(text="Fabric")
        for name in ("fabric_stretch", "fabric_sewing", "fabric_bending", "fabric_density"):
            col.prop(s, name)
        col = self.layout.column(align=True)
        for name in ("mu", "sdf_spacing_mm", "sim_iterations", "steps_per_iteration", "exact_every", "iterations"):
            col.prop(s, name)
        self.layout.prop(s, "device")
        dev = _device()
        if dev["error"]:
            self.layout.label(text=dev["error"], icon="ERROR")
        elif dev["cuda"]:
            self.layout.label(text=f"GPU: {dev['name']}", icon="CHECKMARK")
        else:
            self.layout.label(text=f"CPU: {dev['why']}", icon="INFO")


_device_cache: dict = {}


def _device() -> dict:
    # Asked once per session: the panel redraws often and the answer does not change.
    if not _device_cache:
        _device_cache.update(compute.device_status())
    return _device_cache


class SEAMFIT_PT_cache(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Cached Precomputation"
    bl_parent_id = "SEAMFIT_PT_costs"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        counts = CACHE.counts()
        col = self.layout.column(align=True)
        names = {"mesh": "Sewn meshes", "body": "Bodies", "sdf": "Distance fields",
                 "drape": "Base drapes", "grader": "Factorizations", "grade": "Gradings",
                 "register": "Registered targets"}
        for key, label in names.items():
            col.label(text=f"{label}: {counts.get(key, 0)}  (reused {CACHE.hits.get(key, 0)}×)")
        from . import cache, prefs
        n, size = cache.disk_usage()
        p = prefs.preferences()
        limit = f" of {p.cache_limit_mb:.0f}" if p is not None else ""
        col.label(text=f"On disk: {n} files, {size / 2**20:.0f}{limit} MB")
        self.layout.operator("seamfit.clear_cache", icon="TRASH")


class SEAMFIT_PT_run(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Run"

    def draw(self, context):
        layout = self.layout
        job = jobs.active()
        if job is not None and not job.done:
            snap = job.snapshot()
            layout.progress(factor=snap["fraction"], type="BAR",
                            text=jobs.progress_text(snap))
            if snap["objective"] is not None:
                layout.label(text=f"Objective {snap['objective']:.6g} (iteration {snap['iterations']})")
            layout.label(text=f"{snap['elapsed']:.1f} s   Esc or Cancel stops it")
            layout.operator("seamfit.cancel", icon="CANCEL")
            return
        row = layout.row(align=True)
        row.operator("seamfit.drape", icon="MOD_CLOTH")
        row.operator("seamfit.adjust", icon="MOD_SHRINKWRAP")
        s = context.scene.seamfit
        layout.prop(s, "keep_results")
        _draw_results(layout, s)


class SEAMFIT_PT_stretch(_SeamfitPanel, bpy.types.Panel):
    bl_label = "Stretch Map"
    bl_parent_id = "SEAMFIT_PT_run"

    def draw(self, context):
        s = context.scene.seamfit
        layout = self.layout
        layout.prop(s, "stretch_measure")
        layout.prop(s, "stretch_range")
        if s.stretch_range == "FIXED":
            layout.prop(s, "stretch_span_pct")
        layout.prop(s, "show_legend")
        for obj in scene_io.garments(context.scene)[-4:]:
            st = obj["seamfit_stretch"]
            layout.label(text=f"{obj.name}: {st['min_pct']:+.1f} to {st['max_pct']:+.1f} %, "
                              f"colours ±{st['span_pct']:g} %", icon="COLOR")


def _draw_results(layout, s):
    results = [c for c in bpy.data.collections
               if scene_io.is_pattern_collection(c) and c.seamfit.role in {"drape", "graded"}]
    if not results:
        return
    layout.label(text="Fit (ease: garment minus body girth)")
    for c in results[-4:]:
        box = layout.box()
        box.label(text=c.name, icon="OUTLINER_COLLECTION")
        if c.seamfit.role == "graded" and c.seamfit.method:
            box.label(text=f"{methods.label(c.seamfit.method)}: objective {c.seamfit.objective:.4g} "
                           f"in {c.seamfit.iterations} iterations")
        for w in c.seamfit.warnings:
            box.label(text=w.name, icon="ERROR")
        if c.seamfit.role == "graded":
            row = box.row(align=True)
            op = row.operator("seamfit.compare", icon="SPLIT_HORIZONTAL")
            op.collection, op.layout = c.name, s.compare_layout
            row.prop(s, "compare_layout", text="")
        fit = c.seamfit.fit
        if fit.valid:
            parts = [f"{k.capitalize()} {getattr(fit, k):+.1f}" if getattr(fit, f"has_{k}") else f"{k.capitalize()} –"
                     for k in ("bust", "waist", "hip")]
            box.label(text="   ".join(parts) + " cm")


CLASSES = (SEAMFIT_UL_panels, SEAMFIT_UL_stitches, SEAMFIT_UL_proposals, SEAMFIT_PT_patterns, SEAMFIT_PT_bodies,
           SEAMFIT_PT_measure, SEAMFIT_PT_costs, SEAMFIT_PT_simulation, SEAMFIT_PT_cache, SEAMFIT_PT_run, SEAMFIT_PT_stretch)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
