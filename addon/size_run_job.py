# SPDX-License-Identifier: GPL-3.0-or-later
"""Grade Size Run's computation (no bpy; runs in the worker thread): seamfit's size run
(seamfit.opt.size_run, as ``seamfit grade-run`` runs it) on the scene's pattern and base
body and on target bodies captured from the scene or read from files. Each size starts
from its neighbour's result and all share the base's mesh, field and drape."""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from pathlib import Path

from . import compute
from .compute import AddonError, BodyInput, seamfit_module
from .jobs import Cancelled


@dataclass
class SizeRunInputs:
    run: compute.RunInputs              # pattern, base body and settings (no target)
    targets: list                       # BodyInput (scene objects) or str (body files), as given


@dataclass
class SizeRunOutput:
    labels: list[str]                   # every size in size order, the base among them
    base_index: int
    sizes: dict                         # label -> compute.GradeOutput (the base has none)
    jumps: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    seconds: float = 0.0


def body_file(path: str) -> BodyInput:
    """A target body read from a file as ``seamfit grade-run`` reads it (checked, faces
    oriented), named by the file."""
    if not path:
        raise AddonError("a target of the size run has neither an object nor a file")
    body = seamfit_module("body").checked_body(path)
    return BodyInput(Path(path).stem, body.vertices, body.faces)


def _progress(job, tracker, label: str, k: int, n: int):
    """A size's progress callback: its stages on the job's bar, within its share of the run."""
    def progress(info: dict) -> bool:
        # Called from inside seamfit's solvers: answer False to stop, never raise.
        try:
            snap = tracker.observe(info)
            search = info.get("stage") == "optimize" and info.get("iteration") is not None
            job.update(stage=f"size {label} ({k + 1}/{n}): {snap.stage}", fraction=(k + snap.fraction) / n,
                       objective=info.get("objective") if search else None,
                       iteration=info.get("iteration") if search else None)
        except Cancelled:
            return False
        return not job.cancelled
    return progress


def run(inp: SizeRunInputs, job) -> SizeRunOutput:
    """Grade the pattern to every target in one run (Esc stops it between or within sizes)."""
    from seamfit.errors import SolveError
    size_row = seamfit_module("opt")
    compute.check_device(inp.run.device)
    targets = [t if isinstance(t, BodyInput) else body_file(t) for t in inp.targets]
    if not targets:
        raise AddonError("Grade Size Run: add the target bodies first (scene objects or files)")
    names = [t.name for t in targets]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise AddonError(f"Grade Size Run: two targets are named {', '.join(map(repr, twice))}; "
                         "each size needs its own name")
    pattern = compute.pattern_from_json(inp.run.pattern_json)
    settings = compute.grade_settings(inp.run)
    fabric, sim_settings = compute._sim_objects(inp.run.sim, inp.run.device)
    base = compute.body_object(inp.run.base)
    on_mesh = []
    for t in targets:
        job.update(stage=f"size {t.name}: checking the body")
        body, _ = compute.registered_target(inp.run.base, t, job, show_fraction=False)
        on_mesh.append((t.name, body))
    warnings: list[str] = []
    base_index = size_row.base_place(base, on_mesh, warnings.append)
    base_label = size_row.base_size_label(inp.run.base.name, names)
    progress_module = seamfit_module("progress")
    order: list[str] = []

    def progress_for(label: str):
        order.append(label)
        tracker = progress_module.for_grading(pattern, settings, tolerance=float(sim_settings.tolerance))
        return _progress(job, tracker, label, len(order) - 1, len(targets))

    grade = functools.partial(seamfit_module().grade, fabric=fabric, sim_settings=sim_settings)
    try:
        result = seamfit_module().run_sizes(
            pattern, base, on_mesh, base_index, settings, base_label=base_label, grade_fn=grade,
            progress_for=progress_for)
    except SolveError:
        job.check()             # cancelled: nothing reaches the scene
        raise
    job.check()
    sizes = {t.name: compute.grade_output(dataclasses.replace(inp.run, target=t), result.sizes[t.name].result)
             for t in targets}
    job.update(stage="done", fraction=1.0, eta=0.0)
    return SizeRunOutput(labels=list(result.labels), base_index=result.base_index, sizes=sizes,
                         jumps=list(result.jumps), warnings=warnings, seconds=float(result.seconds))
