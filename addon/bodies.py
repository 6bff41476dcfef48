# SPDX-License-Identifier: GPL-3.0-or-later
"""Bodies made for grading: a body from measurements (a new mesh object carrying its
measurements) and a target of another mesh registered onto the base body's mesh. The
computations are seamfit's (seamfit.body), run as jobs like Drape and Adjust."""
from __future__ import annotations

import bpy
import numpy as np
from bpy.props import BoolProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from . import compute
from .operators import capture_body
from .solve import JobOperator, Task

# Custom properties of a body made from measurements (Object Properties > Custom Properties).
REQUESTED = "seamfit_requested_cm"
ACHIEVED = "seamfit_achieved_cm"
INFERRED = "seamfit_inferred"
MAX_ERROR = "seamfit_max_error_cm"
PROBLEMS = "seamfit_problems"


def is_made_body(obj) -> bool:
    return obj is not None and obj.type == "MESH" and REQUESTED in obj and ACHIEVED in obj


def add_body_object(context, made) -> bpy.types.Object:
    """A new mesh object for seamfit's MeasuredBody, in seamfit's frame (metres, Z up, feet
    on z = 0), with its measurements as custom properties. Nothing else in the scene changes."""
    body = made.body
    name = body.name or "body"
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(body.vertices, dtype=np.float64).tolist(), [],
                     np.asarray(body.faces, dtype=np.int64).tolist())
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    context.scene.collection.objects.link(obj)
    obj[REQUESTED] = {k: round(float(v), 2) for k, v in made.requested.items()}
    obj[ACHIEVED] = {k: round(float(v), 2) for k, v in made.achieved.items()}
    obj[INFERRED] = ", ".join(made.inferred)
    obj[MAX_ERROR] = round(float(made.max_error_cm), 3)
    obj[PROBLEMS] = "; ".join(made.problems)
    obj["seamfit_gender"] = made.gender
    return obj


class SEAMFIT_OT_load_size_chart(bpy.types.Operator, ImportHelper):
    """Load a size chart (seamfit JSON, Seamly2D / Valentina .vst or .vit): its sizes become
    the presets of the Body from Measurements panel"""
    bl_idname = "seamfit.load_size_chart"
    bl_label = "Load Size Chart"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".vst"
    filter_glob: StringProperty(default="*.json;*.vst;*.vit;*.smms;*.smis", options={"HIDDEN"})

    def execute(self, context):
        import json
        try:
            sizes = compute.load_size_chart(self.filepath)
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        m = context.scene.seamfit.measure
        m.chart_sizes.clear()
        for size in sizes:
            item = m.chart_sizes.add()
            item.name, item.gender, item.values_cm = size["name"], size["gender"], json.dumps(size["cm"])
        m.chart = self.filepath
        m.size = "0"                    # the first size fills the fields
        self.report({"INFO"}, f"Loaded {len(sizes)} size(s) from {bpy.path.basename(self.filepath)}: "
                              + ", ".join(s["name"] for s in sizes))
        return {"FINISHED"}


class SEAMFIT_OT_body_from_measurements(JobOperator, bpy.types.Operator):
    """Add a body made to the measurements of the Body from Measurements panel (seamfit's
    body model; measurements left at 0 are inferred)"""
    bl_idname = "seamfit.body_from_measurements"
    bl_label = "Add Body"

    set_target: BoolProperty(name="Make it the target body", default=True,
                             description="Pick the new body as the target body of the grading")

    def make_task(self, context) -> Task:
        m = context.scene.seamfit.measure
        cm, gender = m.requested_cm(), m.gender
        name = m.body_name.strip() or "body"
        set_target = self.set_target

        def apply(ctx, made) -> str:
            obj = add_body_object(ctx, made)
            if set_target:
                ctx.scene.seamfit.target_body = obj
            text = (f"Added {obj.name!r} from {len(made.set)} measurement(s), {len(made.inferred)} inferred: "
                    f"within {made.max_error_cm:.2f} cm of the requested values ({made.seconds:.1f} s)")
            return text + "".join(f"; warning: {p}" for p in made.problems)
        return Task(f"body {name}", lambda job: compute.make_body(cm, gender, name, job), apply)


class SEAMFIT_OT_register_target(JobOperator, bpy.types.Operator):
    """Fit the base body's mesh onto a target body of another mesh (a scan, a character),
    as grading does, and show how close it came"""
    bl_idname = "seamfit.register_target"
    bl_label = "Register Target"

    def make_task(self, context) -> Task:
        s = context.scene.seamfit
        if s.base_body is None or s.target_body is None:
            raise compute.AddonError("pick the base and the target body in the Bodies panel")
        depsgraph = context.evaluated_depsgraph_get()
        base, target = capture_body(s.base_body, depsgraph), capture_body(s.target_body, depsgraph)

        def apply(ctx, out) -> str:
            _, reg = out
            rep = ctx.scene.seamfit.target_report
            if reg is None:
                rep.registering = rep.registered = False
                return f"{target.name} has the base body's mesh: it needs no registration"
            show_registration(rep, reg)
            return (f"Registered {base.name}'s mesh onto {target.name}: {reg.mean_mm:.1f} mm mean, "
                    f"{reg.max_mm:.1f} mm max from its surface ({reg.seconds:.0f} s)")
        return Task(f"register {target.name}", lambda job: compute.registered_target(base, target, job), apply)


def show_registration(rep, reg) -> None:
    """Keep a registration's error in a body report (shown in the Bodies panel)."""
    rep.registering = rep.registered = True
    rep.registration_mean_mm = float(reg.mean_mm)
    rep.registration_max_mm = float(reg.max_mm)


CLASSES = (SEAMFIT_OT_load_size_chart, SEAMFIT_OT_body_from_measurements, SEAMFIT_OT_register_target)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
