# SPDX-License-Identifier: GPL-3.0-or-later
"""The sidebar panels draw (headless Blender has no UI to draw into, so the layout is a
recorder that checks every property and operator a panel names really exists)."""
import bpy

from helpers import BODY_BASE, KEIKO, PENCIL, addon, import_obj


class Recorder:
    def __init__(self, log):
        self.log = log

    def _child(self, *args, **kwargs):
        return Recorder(self.log)

    row = column = box = split = column_flow = grid_flow = _child

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"{data.bl_rna.identifier} has no property {name!r}"
        self.log.append(("prop", name))

    def operator(self, idname, **kwargs):
        mod, _, op = idname.partition(".")
        assert hasattr(getattr(bpy.ops, mod), op), idname
        self.log.append(("operator", idname))
        return _OpProps(getattr(getattr(bpy.ops, mod), op).get_rna_type())

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def template_list(self, listtype, list_id, data, propname, active_data, active_propname, **kwargs):
        assert hasattr(bpy.types, listtype)
        assert propname in data.bl_rna.properties and active_propname in active_data.bl_rna.properties
        self.log.append(("list", propname, len(getattr(data, propname))))

    def progress(self, factor=0.0, type="BAR", text=""):
        assert 0.0 <= factor <= 1.0
        self.log.append(("progress", text))

    def separator(self, **kwargs):
        pass


class _OpProps:
    """Operator properties set from a panel must exist on the operator."""

    def __init__(self, rna):
        object.__setattr__(self, "_rna", rna)

    def __setattr__(self, name, value):
        assert name in self._rna.properties, f"operator has no property {name!r}"


def _draw_all(context):
    log = []
    for name in ("SEAMFIT_PT_patterns", "SEAMFIT_PT_bodies", "SEAMFIT_PT_measure", "SEAMFIT_PT_costs", "SEAMFIT_PT_simulation",
                 "SEAMFIT_PT_cache", "SEAMFIT_PT_run", "SEAMFIT_PT_size_run"):
        panel = getattr(bpy.types, name)
        holder = type("P", (), {"layout": Recorder(log)})()
        panel.draw(holder, context)
    return log


def test_panels_draw_empty_scene(scene):
    log = _draw_all(bpy.context)
    labels = [e[1] for e in log if e[0] == "label"]
    assert any("No pattern" in t for t in labels)
    ops = {e[1] for e in log if e[0] == "operator"}
    assert {"seamfit.import_pattern", "seamfit.check_bodies", "seamfit.drape", "seamfit.adjust",
            "seamfit.clear_cache", "seamfit.load_size_chart", "seamfit.body_from_measurements",
            "seamfit.grade_size_run", "seamfit.run_target_add", "seamfit.run_target_add_file"} <= ops


def test_patterns_panel_lists_the_proposed_stitches_of_a_dxf(scene):
    bpy.ops.seamfit.import_pattern(filepath=str(KEIKO))
    log = _draw_all(bpy.context)
    lists = {e[1]: e[2] for e in log if e[0] == "list"}
    assert lists == {"panels": 2, "stitches": 0, "proposals": 3, "run_targets": 0}
    ops = [e[1] for e in log if e[0] == "operator"]
    assert "seamfit.confirm_stitches" in ops and ops.count("seamfit.export_pattern") == 4
    labels = [e[1] for e in log if e[0] == "label"]
    assert any(t.startswith("lengths ") for t in labels)      # why the active proposal is proposed


def test_panels_draw_pattern_and_bodies(scene):
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    s = scene.seamfit
    s.base_body = import_obj(BODY_BASE, "base")
    bpy.ops.seamfit.check_bodies()
    log = _draw_all(bpy.context)
    lists = {e[1]: e[2] for e in log if e[0] == "list"}
    assert lists == {"panels": 4, "stitches": 20, "run_targets": 0}
    labels = [e[1] for e in log if e[0] == "label"]
    assert any(t.startswith("Height ") for t in labels)
    assert any(t.startswith("Bust ") and "Waist" in t and "Hip" in t for t in labels)


def test_run_panel_shows_progress_while_a_job_runs(scene):
    import threading
    jobs = addon().jobs
    gate = threading.Event()

    def fn(job):
        job.callback("testing", max_iterations=10)(3, 0.25)
        gate.wait(10)
        return None

    job = jobs.begin(jobs.Job("test job", fn))
    try:
        while not job.history:
            pass
        log = _draw_all(bpy.context)
        assert ("progress", "testing 40%") in log
        assert ("operator", "seamfit.cancel") in log
        assert any(e[0] == "label" and "Objective 0.25" in e[1] for e in log)
        assert not bpy.ops.seamfit.drape.poll()
    finally:
        gate.set()
        job.wait(10)
        jobs.end(job)
