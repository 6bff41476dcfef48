"""One job's process (``python -m seamfit.batch.job SPEC``), started by its Ray task.

A process of its own per job: its log holds everything the job printed (native code
included), its thread count is set before any library loads, and its memory goes back
when it ends. It dies with the task's worker (PR_SET_PDEATHSIG: SIGTERM, which grade
handles as Ctrl-C, leaving no half-written set), so a killed worker leaves no grading
running behind the retry.

SPEC is JSON: {"op": "grade", "argv": [...], "make_body": {...}} runs ``seamfit`` with
argv, after making the target body from measurements when asked; {"op": "prepare",
"argv": [...]} computes a base's shared work into the disk cache.
"""
from __future__ import annotations

import json
import signal
import sys

PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import os
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:              # the parent died before the call
        os.kill(os.getpid(), signal.SIGTERM)


def make_body(spec: dict) -> None:
    """The target body from a measurement file (its one body, or the size ``size`` of a
    chart), written to ``spec["out"]`` (atomically)."""
    from ..body import from_measurements, load_measurement_sets, save_body
    from ..errors import SeamfitError
    sets = load_measurement_sets(spec["file"])
    size = spec.get("size")
    if size is None:
        if len(sets) != 1:
            raise SeamfitError(f"{spec['file']}: holds {len(sets)} bodies ({', '.join(s.name for s in sets)}); "
                               "give size, or size_chart for a size run")
        mset = sets[0]
    else:
        found = [s for s in sets if s.name in (size, f"size{size}")]
        if not found:
            raise SeamfitError(f"{spec['file']}: has no size {size!r} (its sizes: {', '.join(s.name for s in sets)})")
        mset = found[0]
    print(f"seamfit batch: making the body of {mset.where}", file=sys.stderr)
    save_body(from_measurements(mset).body, spec["out"])


def prepare_base(argv: list[str]) -> int:
    """The sewn mesh, the base body's field and the base drape, as ``seamfit grade`` makes
    them, so that they land in the content-keyed cache under the keys grade will ask for
    (the drape's key is made by ``seamfit.opt.prepare.base_drape`` itself). A field cut to
    the garment is left to the jobs."""
    import argparse
    from dataclasses import replace
    from pathlib import Path
    from ..body import checked_body
    from ..commands.checks import checked_pattern
    from ..commands.grade import add_grade_options, check_grade_options, settings_from_args
    from ..device import choose_device
    from ..mesh import build_sewn_mesh
    from ..opt.prepare import base_drape
    from ..opt.sdf_region import body_field, resolve_sdf_region
    from ..sim.model import Fabric, SimSettings

    p = argparse.ArgumentParser(prog="seamfit batch (base)")
    p.add_argument("pattern", type=Path)
    p.add_argument("base_body", type=Path)
    add_grade_options(p, truth=False)
    args = p.parse_args(argv)
    check_grade_options(args)
    pattern = checked_pattern(args.pattern, args.edge_length)
    body = checked_body(args.base_body)
    settings = settings_from_args(args, pattern)
    mesh = build_sewn_mesh(pattern, edge_length_cm=settings.edge_length_cm)
    if resolve_sdf_region(settings.sdf_region, body, settings.sdf_spacing) != "body":
        print("seamfit batch: the base field is cut to the garment: each job builds its own", file=sys.stderr)
        return 0
    device = choose_device(settings.device, problem_size=int(mesh.n_vertices))["device"]
    sdf, _ = body_field(body, settings.sdf_spacing, "body", device=device)
    _, info = base_drape(mesh, pattern, body, sdf, Fabric(), replace(SimSettings(), device=device))
    drape = "from the cache" if info.get("cached") else f"{info.get('seconds', 0.0):.1f} s"
    print(f"seamfit batch: base ready: {mesh.n_vertices} vertices, drape {drape}", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    _die_with_parent()
    spec = json.loads((argv if argv is not None else sys.argv[1:])[0])
    if spec["op"] == "prepare":
        from ..cli import run_guarded
        return run_guarded("batch", lambda: prepare_base(spec["argv"]))
    if spec.get("make_body"):
        from ..cli import run_guarded
        code = run_guarded("batch", lambda: make_body(spec["make_body"]))
        if code:
            return code
    from ..cli import main as cli_main
    return cli_main(spec["argv"])


if __name__ == "__main__":
    sys.exit(main())
