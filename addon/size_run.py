# SPDX-License-Identifier: GPL-3.0-or-later
"""Grade Size Run: the base pattern graded to several target bodies (scene objects or
files) in one job, each size's curves in its own collection, and the run's multi-size DXF
with its grade rules (RUL) as ``seamfit grade-run`` writes them."""
from __future__ import annotations

from pathlib import Path

import bpy
from bpy.props import IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import compute, dxf_io, scene_io, size_run_job, solve
from .operators import capture_body


def size_run_task(context) -> solve.Task:
    s = context.scene.seamfit
    inputs = solve._run_inputs(context, with_target=False)
    depsgraph = context.evaluated_depsgraph_get()
    targets, objects = [], {}
    for k, t in enumerate(s.run_targets):
        if t.obj is not None:
            targets.append(capture_body(t.obj, depsgraph))
            objects[t.obj.name] = t.obj.name
        elif t.filepath:
            targets.append(bpy.path.abspath(t.filepath))
        else:
            raise compute.AddonError(f"Grade Size Run: target {k + 1} has neither an object nor a file")
    inp = size_run_job.SizeRunInputs(run=inputs, targets=targets)
    base_name = s.pattern.name
    key = compute.digest("size_run", inputs.pattern_json, round(inputs.edge_length_cm, 6), inputs.base.key,
                         [t.key if isinstance(t, compute.BodyInput) else t for t in targets], inputs.sim,
                         inputs.strengths, inputs.grade, inputs.method, inputs.grade_options, inputs.device)
    slot = scene_io.slot_name("size_run", base_name)
    same = scene_io.reusable(slot, key)
    if same is not None:        # the same inputs: the result in the scene stands, nothing is computed
        return solve.Task(f"size run of {base_name}", lambda job: None,
                          lambda ctx, out: f"{base_name}: the size run in {same.name!r} is up to date")

    def apply(ctx, out) -> str:
        def build(c, n, made):
            bodies = {lab: bpy.data.objects.get(name) for lab, name in objects.items()}
            return scene_io.build_size_run(c, out, n, base_name, made, bodies, inputs.edge_length_cm)
        coll, reused = solve._place(ctx, slot, key, f"{base_name} size run", build)
        sizes = [lab for k, lab in enumerate(out.labels) if k != out.base_index]
        worst = max(out.jumps, key=lambda j: j["back_mm"], default=None)
        jumps = "" if worst is None else (
            f"; warning: {len(out.jumps)} landmark move(s) out of size order, the largest {worst['panel']} "
            f"{worst['landmark']} {worst['back_mm']:.1f} mm back from {worst['from']} to {worst['to']}")
        return (f"Graded {base_name} to {len(sizes)} sizes ({', '.join(sizes)}) in {out.seconds:.1f} s; "
                f"results in {coll.name!r}" + (" (unchanged)" if reused else "") + jumps
                + "".join(f"; warning: {w}" for w in out.warnings))
    return solve.Task(f"size run of {base_name}", lambda job: size_run_job.run(inp, job), apply)


class SEAMFIT_OT_grade_size_run(solve.JobOperator, bpy.types.Operator):
    """Grade the base pattern to every target body of the size run in one job (each size starts
    from its neighbour's result; Esc cancels): each size's curves in a collection of its own"""
    bl_idname = "seamfit.grade_size_run"
    bl_label = "Grade Size Run"

    def make_task(self, context):
        return size_run_task(context)


class SEAMFIT_OT_run_target_add(bpy.types.Operator):
    """Add the selected mesh objects (but the base body) as target bodies of the size run"""
    bl_idname = "seamfit.run_target_add"
    bl_label = "Add Selected"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.seamfit
        have = {t.obj for t in s.run_targets if t.obj is not None}
        added = [o for o in context.selected_objects
                 if o.type == "MESH" and o is not s.base_body and o not in have]
        if not added:
            self.report({"ERROR"}, "select the target body objects (meshes other than the base body) first")
            return {"CANCELLED"}
        for obj in added:
            s.run_targets.add().obj = obj
        return {"FINISHED"}


class SEAMFIT_OT_run_target_add_file(bpy.types.Operator, ImportHelper):
    """Add a body file (.obj/.ply) as a target body of the size run (read when the run starts)"""
    bl_idname = "seamfit.run_target_add_file"
    bl_label = "Add Body File"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".obj"
    filter_glob: StringProperty(default="*.obj;*.ply", options={"HIDDEN"})

    def execute(self, context):
        context.scene.seamfit.run_targets.add().filepath = self.filepath
        return {"FINISHED"}


class SEAMFIT_OT_run_target_remove(bpy.types.Operator):
    """Remove a target body from the size run"""
    bl_idname = "seamfit.run_target_remove"
    bl_label = "Remove Target"
    bl_options = {"REGISTER", "UNDO"}

    index: IntProperty(default=-1, description="Which target (the active one when -1)")

    def execute(self, context):
        s = context.scene.seamfit
        k = self.index if self.index >= 0 else s.active_run_target
        if not 0 <= k < len(s.run_targets):
            return {"CANCELLED"}
        s.run_targets.remove(k)
        s.active_run_target = min(s.active_run_target, max(0, len(s.run_targets) - 1))
        return {"FINISHED"}


class SEAMFIT_OT_export_size_run(bpy.types.Operator, ExportHelper):
    """Export a graded size run: every size in one DXF-ASTM file, and the base size with
    grade-rule numbers (.graded.dxf) and its grade-rule table (.rul) beside it"""
    bl_idname = "seamfit.export_size_run"
    bl_label = "Export Size Run DXF"
    bl_options = {"REGISTER"}

    filename_ext = ".dxf"
    filter_glob: StringProperty(default="*.dxf", options={"HIDDEN"})
    collection: StringProperty(name="Size run", description="Name of the size run's collection (the newest "
                               "when empty)")

    def execute(self, context):
        try:
            coll = scene_io.chosen_collection(self.collection, lambda c: scene_io.SIZE_RUN_KEY in c, "size run",
                                              "no size run to export: run Grade Size Run first")
            patterns, labels, base_index = scene_io.size_run_patterns(coll)
            written = dxf_io.write_size_run(patterns, labels, base_index, self.filepath,
                                            source=patterns[base_index].source_file)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {coll.name} ({len(labels)} sizes) to {', '.join(written)}")
        return {"FINISHED"}


class SEAMFIT_UL_run_targets(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        if item.obj is not None:
            layout.label(text=item.obj.name, icon="OUTLINER_OB_MESH")
        else:
            layout.label(text=Path(item.filepath).name or "(no body)", icon="FILE")


class SEAMFIT_PT_size_run(bpy.types.Panel):
    bl_label = "Grade Size Run"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "seamfit"
    bl_parent_id = "SEAMFIT_PT_run"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        s = context.scene.seamfit
        layout = self.layout
        layout.label(text="Target bodies, smallest to largest")
        row = layout.row()
        row.template_list("SEAMFIT_UL_run_targets", "", s, "run_targets", s, "active_run_target", rows=3)
        col = row.column(align=True)
        col.operator("seamfit.run_target_add", text="", icon="ADD")
        col.operator("seamfit.run_target_add_file", text="", icon="FILE_FOLDER")
        col.operator("seamfit.run_target_remove", text="", icon="REMOVE")
        layout.operator("seamfit.grade_size_run", icon="MOD_SHRINKWRAP")
        for coll in [c for c in bpy.data.collections if scene_io.SIZE_RUN_KEY in c][-2:]:
            layout.operator("seamfit.export_size_run", text=f"Export {coll.name} (DXF, RUL)",
                            icon="EXPORT").collection = coll.name


CLASSES = (SEAMFIT_OT_grade_size_run, SEAMFIT_OT_run_target_add, SEAMFIT_OT_run_target_add_file,
           SEAMFIT_OT_run_target_remove, SEAMFIT_OT_export_size_run, SEAMFIT_UL_run_targets, SEAMFIT_PT_size_run)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
