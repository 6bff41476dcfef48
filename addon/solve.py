# SPDX-License-Identifier: GPL-3.0-or-later
"""Drape and adjust: tasks captured on the main thread, computed in a worker thread,
applied to the scene on the main thread.

From the UI the operators run modally (progress bar, live objective, Esc cancels);
from scripts and ``blender --background`` the same operators run to the end in the
calling thread. Either way nothing in the scene changes until the computation has
finished, so a failed or cancelled run leaves the scene as it was.
"""
from __future__ import annotations

import traceback
from dataclasses import dataclass
from typing import Any, Callable

import bpy

from . import compute, dxf_io, jobs, methods, props, scene_io
from .operators import capture_body


_last: dict = {}


def last_result(kind: str = "adjust"):
    """The outcome of the last finished drape or adjust of this session (batch scripts
    write seamfit's files from it)."""
    return _last.get(kind)


@dataclass
class Task:
    label: str
    compute: Callable[[jobs.Job], Any]             # worker thread, no bpy
    apply: Callable[[Any, Any], str]               # main thread: (context, result) -> message


def _run_inputs(context, with_target: bool) -> compute.RunInputs:
    s = context.scene.seamfit
    coll = s.pattern
    if coll is None:
        raise compute.AddonError("no pattern: import one or pick it in the Patterns panel")
    if s.base_body is None:
        raise compute.AddonError("pick the base body in the Bodies panel")
    if with_target and s.target_body is None:
        raise compute.AddonError("pick the target body in the Bodies panel")
    pattern = scene_io.pattern_from_collection(coll)
    dxf_io.check_drapable(pattern)      # a DXF pattern: its stitches confirmed, its panels placed
    depsgraph = context.evaluated_depsgraph_get()
    cfg = props.settings_dict(s)
    grade = dict(cfg["grade"])
    edge, device, spacing = grade.pop("edge_length_cm"), grade.pop("device"), grade.pop("sdf_spacing")
    return compute.RunInputs(
        pattern_name=coll.name, pattern_json=compute.pattern_to_json(pattern),
        edge_length_cm=edge, base=capture_body(s.base_body, depsgraph),
        sim={**cfg["sim"], "fabric": cfg["fabric"], "sdf_spacing": spacing},
        target=capture_body(s.target_body, depsgraph) if with_target else None,
        strengths=cfg["strengths"], grade=grade, device=device, method=cfg["method"],
        grade_options=cfg["grade_options"])


def _inputs_key(kind: str, inp: compute.RunInputs) -> str:
    """What a result depends on: the same key means the same result."""
    target = inp.target.key if inp.target is not None else ""
    return compute.digest(kind, inp.pattern_json, round(inp.edge_length_cm, 6), inp.base.key, target, inp.sim,
                          inp.device, *((inp.strengths, inp.grade, inp.method, inp.grade_options) if kind == "adjust" else ()))


def _place(ctx, slot: str, key: str, name: str, build) -> tuple:
    """(collection, reused): the slot's result when its inputs are unchanged, else a new
    result replacing it (or beside it, with Keep previous results)."""
    same = scene_io.reusable(slot, key)
    if same is not None:
        return same, True
    keep = ctx.scene.seamfit.keep_results
    return scene_io.place_result(ctx, slot, key, name, build, keep=keep), False


def _object(name: str):
    return bpy.data.objects.get(name)


def mesh_task(context) -> Task:
    s = context.scene.seamfit
    if s.pattern is None:
        raise compute.AddonError("no pattern: import one or pick it in the Patterns panel")
    name = s.pattern.name
    text = compute.pattern_to_json(scene_io.pattern_from_collection(s.pattern))
    edge = float(s.edge_length_cm)
    key = compute.digest("mesh", text, round(edge, 6))

    def apply(ctx, out) -> str:
        coll, reused = _place(ctx, scene_io.slot_name("mesh", name), key, f"{name} sewn mesh",
                              lambda c, n, made: scene_io.build_sewn(c, out, n, made))
        g = out.garment
        return (f"Meshed {name} at {edge:g} cm: {len(g.x)} vertices, {len(g.triangles)} triangles, "
                f"{len(g.sewing_pairs)} sewing pairs in {coll.name!r}" + (" (unchanged)" if reused else ""))
    return Task(f"mesh {name}", lambda job: compute.run_mesh(text, edge, job), apply)


def drape_task(context) -> Task:
    inputs = _run_inputs(context, with_target=False)
    key = _inputs_key("drape", inputs)
    slot = scene_io.slot_name("drape", inputs.pattern_name, inputs.base.name)

    def apply(ctx, out) -> str:
        def build(c, n, made):
            return scene_io.build_drape(c, out, n, body=inputs.base.name, made=made,
                                        body_object=_object(inputs.base.name),
                                        edge_length_cm=inputs.edge_length_cm)
        coll, reused = _place(ctx, slot, key, f"{inputs.pattern_name} on {inputs.base.name}", build)
        _last["drape"] = out
        state = "converged" if out.converged else f"not converged ({out.message})"
        return (f"Draped {inputs.pattern_name} on {inputs.base.name}: {state}; result in {coll.name!r}"
                + (" (unchanged)" if reused else ""))
    return Task(f"drape {inputs.pattern_name}", lambda job: compute.run_drape(inputs, job), apply)


def adjust_task(context) -> Task:
    inputs = _run_inputs(context, with_target=True)
    base_coll_name = context.scene.seamfit.pattern.name
    key = _inputs_key("adjust", inputs)
    slot = scene_io.slot_name("adjust", base_coll_name, inputs.target.name)

    def apply(ctx, out) -> str:
        def build(c, n, made):
            return scene_io.build_graded(c, out, n, base_collection=base_coll_name, body=inputs.target.name,
                                         made=made, body_object=_object(inputs.target.name),
                                         edge_length_cm=inputs.edge_length_cm)
        coll, reused = _place(ctx, slot, key, f"{inputs.target.name} {inputs.pattern_name}", build)
        _last["adjust"] = out
        reg = out.registration
        if reg is not None:
            from .bodies import show_registration
            show_registration(ctx.scene.seamfit.target_report, reg)
        state = "converged" if out.converged else f"stopped: {out.message}"
        return (f"Graded {inputs.pattern_name} to {inputs.target.name} with {methods.label(out.method)} "
                f"in {out.iterations} iterations ({state}, objective {out.objective:.4g}); "
                f"result in {coll.name!r}" + (" (unchanged)" if reused else "")
                + (f"; the target was registered onto the base body's mesh ({reg.mean_mm:.1f} mm mean, "
                   f"{reg.max_mm:.1f} mm max from its surface)" if reg is not None else "")
                + "".join(f"; warning: {w}" for w in out.warnings))
    return Task(f"grade {inputs.pattern_name} to {inputs.target.name}",
                lambda job: compute.run_grade(inputs, job), apply)


class Runner:
    """The main-thread side of one task: start the worker, poll it, finish."""

    def __init__(self, task: Task):
        self.task = task
        self.job = jobs.Job(task.label, task.compute)

    def start(self) -> "Runner":
        jobs.begin(self.job)
        return self

    def run_here(self) -> "Runner":
        active = jobs.active()
        if active is not None and not active.done:
            raise compute.AddonError(f"seamfit is busy with {active.label}")
        self.job.run_here()
        return self

    def cancel(self) -> None:
        self.job.cancel()

    def answered(self) -> bool:
        """Whether the operator can end now: the job finished, or it was cancelled. A
        cancelled job is not waited for: a step that cannot stop at once (a body field being
        built) runs on in its thread, and its outcome is dropped; the scene is not touched."""
        return self.job.done or self.job.cancelled

    def finish(self, context) -> tuple[str, str]:
        """Apply a finished job. Returns (status, message): status is FINISHED,
        CANCELLED or ERROR; only FINISHED changed the scene."""
        jobs.end(self.job)
        job = self.job
        if job.cancelled:
            return "CANCELLED", f"{job.label} cancelled; the scene is unchanged"
        if job.error is not None:
            if isinstance(job.error, compute.user_errors()):
                return "ERROR", str(job.error)
            print(job.error_trace)
            return "ERROR", f"internal error in {job.label}: {job.error!r} (details in the console)"
        try:
            return "FINISHED", self.task.apply(context, job.result)
        except compute.user_errors() as exc:
            return "ERROR", str(exc)
        except Exception as exc:
            traceback.print_exc()
            return "ERROR", f"internal error applying {job.label}: {exc!r}"


def _redraw_ui(context) -> None:
    wm = context.window_manager
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in {"VIEW_3D", "PROPERTIES"}:
                area.tag_redraw()


class JobOperator:
    bl_options = {"UNDO"}   # one undo step when the result lands; no redo panel (it would recompute)

    def make_task(self, context) -> Task:
        raise NotImplementedError

    @classmethod
    def poll(cls, context):
        job = jobs.active()
        return job is None or job.done

    def _report_end(self, status: str, message: str):
        level = {"FINISHED": "INFO", "CANCELLED": "WARNING"}.get(status, "ERROR")
        self.report({level}, message)
        return {"FINISHED"} if status == "FINISHED" else {"CANCELLED"}

    def execute(self, context):
        try:
            runner = Runner(self.make_task(context)).run_here()
        except compute.user_errors() as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return self._report_end(*runner.finish(context))

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:   # no event loop to drive a modal run
            return self.execute(context)
        try:
            self._runner = Runner(self.make_task(context)).start()
        except (RuntimeError, *compute.user_errors()) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        runner = self._runner
        if event.type == "ESC" and event.value == "PRESS":
            runner.cancel()
        elif event.type != "TIMER":
            return {"PASS_THROUGH"}
        snap = runner.job.snapshot()
        wm = context.window_manager
        wm.progress_update(int(100 * snap["fraction"]))
        text = f"seamfit: {jobs.progress_text(snap)}"
        if snap["objective"] is not None:
            text += f", objective {snap['objective']:.6g}"
        if context.workspace is not None:
            context.workspace.status_text_set(text + "   Esc: cancel")
        _redraw_ui(context)
        if not runner.answered():
            return {"PASS_THROUGH"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        return self._report_end(*runner.finish(context))


class SEAMFIT_OT_build_mesh(JobOperator, bpy.types.Operator):
    """Mesh the pattern at the mesh resolution: panels as faces, seams as loose sewing edges
    (ready for Blender's cloth simulation with sewing)"""
    bl_idname = "seamfit.build_mesh"
    bl_label = "Sewn Mesh"

    def make_task(self, context):
        return mesh_task(context)


class SEAMFIT_OT_drape(JobOperator, bpy.types.Operator):
    """Drape the base pattern on the base body (result: a new mesh coloured by stretch)"""
    bl_idname = "seamfit.drape"
    bl_label = "Drape"

    def make_task(self, context):
        return drape_task(context)


class SEAMFIT_OT_adjust(JobOperator, bpy.types.Operator):
    """Grade the base pattern to the target body (result: new panel curves in a new collection)"""
    bl_idname = "seamfit.adjust"
    bl_label = "Adjust Pattern"

    def make_task(self, context):
        return adjust_task(context)


class SEAMFIT_OT_cancel(bpy.types.Operator):
    """Stop the running drape or grading (the scene stays as it was)"""
    bl_idname = "seamfit.cancel"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        job = jobs.active()
        return job is not None and not job.done

    def execute(self, context):
        jobs.active().cancel()
        return {"FINISHED"}


CLASSES = (SEAMFIT_OT_build_mesh, SEAMFIT_OT_drape, SEAMFIT_OT_adjust, SEAMFIT_OT_cancel)


register, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def unregister():
    jobs.cancel_all()
    _unregister_classes()
