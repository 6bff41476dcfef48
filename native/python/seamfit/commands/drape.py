"""``seamfit drape PATTERN BODY --out DIR``: sew a pattern and dress it on a body.

Writes DIR/garment.obj (the draped garment: 3D positions in the sewn mesh's vertex
order, vt = pattern coordinates in cm, one group per panel), DIR/report.json
(iterations, seconds, residual, seams, contact, energy terms, sizes) and
DIR/drape.png (front, side and back views), as one set: written into a temporary
folder beside DIR and moved into place (an existing non-empty DIR only with --force).
The picture is drawn last; one that cannot be drawn (no matplotlib, a drawing error) is
a warning and a ``pictures`` entry in the report, and the other files are still written.
Progress goes to stderr. Exit code 0 when the files are written, settled or not (the
report and the console say which; --fail-unconverged makes a drape that stopped before
settling exit 1), 2 on an error.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from ..output_set import OutputSet
from ..pictures import draw_pictures, skipped
from .parsing import add_command, add_outcome_options, warner

EPILOG = """\
The garment starts from the pattern's placement (GarmentCode: exact; FreeSewing:
hints, wrapped onto a cylinder around the body first), is sewn with gravity off,
then settles under gravity until the net force falls below --tolerance times the
garment's weight (relative residual). See docs/simulator.md.
"""


def register(subparsers) -> None:
    from .. import settings
    from ..sim import SimSettings
    st = SimSettings()
    p = add_command(subparsers, "drape", EPILOG)
    p.add_argument("pattern", metavar="PATTERN", type=Path, help="pattern file (sewpat-1 or GarmentCode .json)")
    p.add_argument("body", metavar="BODY", type=Path, help="body mesh (.obj or .ply, metres, Z up, facing -Y)")
    p.add_argument("--out", metavar="DIR", type=Path, required=True,
                   help="output folder (created if missing): garment.obj, report.json, drape.png")
    settings.add_options(p, "drape")
    p.add_argument("--max-iterations", metavar="N", type=int, default=None,
                   help=f"iteration budget per stage (default {st.max_iterations} for chebyshev, "
                        f"{st.newton_max_iterations} for newton)")
    p.add_argument("--no-coarse-start", action="store_true",
                   help="no restart from a drape at twice the edge length when the settle stagnates "
                        "(see docs/simulator.md)")
    p.add_argument("--no-polish", action="store_true",
                   help="chebyshev: no Newton polish when the settle stage stops above the tolerance")
    p.add_argument("--dress", choices=("auto", "wrap", "none"), default="auto",
                   help="start positions: wrap hint placements around the body (auto), wrap every "
                        "panel (wrap), or use the placement as is (none)")
    add_outcome_options(p, "the drape stopped before settling", "files", "drape.png")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import settings
    from ..device import check_device
    from ..body import checked_body
    from .checks import checked_pattern, whole

    check_device(args.device)  # fails at once, with the reason, when cuda cannot run here
    settings.check_options(args, "drape")
    whole("--max-iterations", args.max_iterations, 0)
    out = Path(args.out)
    t0 = time.perf_counter()

    warn = warner("drape", args.quiet)

    # the checks of seamfit validate and the size limits, before any meshing or SDF
    pattern = checked_pattern(args.pattern, args.edge_length, warn)
    body = checked_body(args.body, warn)
    if not args.no_picture:   # matplotlib loads while the body fields are built (seamfit.preload)
        from .. import preload
        preload.want("matplotlib.pyplot")
    # Named stages, the share done and the time left: a bar on a terminal, plain lines in
    # a log (seamfit.progress); -q: none.
    from ..progress import ConsoleProgress, for_drape
    console = None if args.quiet else ConsoleProgress(for_drape(
        pattern, args.edge_length, args.sdf_spacing, device=args.device, tolerance=args.tolerance,
        pictures=0 if args.no_picture else 1))
    try:
        with OutputSet(out, inputs=[args.pattern, args.body], force=args.force) as tmp:
            return _drape(args, pattern, body, tmp, out, t0, console)
    except BaseException:
        if console is not None:
            console.fail()      # the error's line starts on a line of its own
        raise


def _drape(args, pattern, body, tmp: Path, out: Path, t0: float, console=None) -> int:
    """Mesh, dress and settle; write the set into ``tmp`` (moved to ``out`` afterwards)."""
    from .. import settings as table
    from ..device import choose_device
    from ..fileio import atomic_write_text
    from ..mesh import build_sewn_mesh, write_obj
    from ..opt import body_field
    from ..sim import Fabric, SimSettings, Simulator
    from ..sim import initial_positions
    from ..sim import drape_coarse_to_fine

    def say(msg: str) -> None:
        if console is not None:
            console.print(msg)

    def stage(name: str) -> None:
        if console is not None:
            console.enter(name)

    stage("meshing")
    mesh = build_sewn_mesh(pattern, args.edge_length)
    say(f"mesh: {mesh.n_vertices} vertices, {len(mesh.triangles)} triangles, "
        f"{len(mesh.sewing_pairs)} sewing pairs")
    # On the GPU, Newton's steps are solved by MINRES there (docs/gpu_backend.md), and the body's
    # field is built there too.
    device_choice = choose_device(args.device, problem_size=int(mesh.n_vertices))
    device = device_choice["device"]
    stage("body fields")
    sdf, field = body_field(body, args.sdf_spacing, "body", device=device)
    say(f"body SDF: {'x'.join(str(d) for d in sdf.values.shape[::-1])} nodes at {sdf.spacing * 1000:g} mm"
        + (f" ({field['device_note']})" if field.get("device_note") else ""))
    fabric = Fabric(**table.from_options(args, "fabric", "drape"))
    settings = SimSettings(**table.from_options(args, "sim", "drape"), polish=not args.no_polish, device=device)
    if args.max_iterations is not None:
        if args.method == "newton":
            settings.newton_max_iterations = args.max_iterations
        else:
            settings.max_iterations = args.max_iterations
    x0, dress = initial_positions(mesh, pattern, sdf, mode=args.dress)
    if dress.get("wrapped_panels"):
        say(f"dressing: wrapped {', '.join(dress['wrapped_panels'])} on a cylinder of radius "
            f"{dress['radius'] * 100:.1f} cm")
    sim = Simulator(mesh, sdf, fabric, settings)
    t_setup = time.perf_counter() - t0
    every = max(settings.progress_every, 1000 if args.method == "chebyshev" else 1)

    def progress(it, res):
        if console is not None:
            console({"stage": "drape", "sim_iteration": it, "residual": res, "log": it % every == 0})
        return True

    stage("drape")

    if args.no_coarse_start:
        result = sim.drape(x0, progress=progress)
    else:
        result = drape_coarse_to_fine(sim, pattern, mode=args.dress, progress=progress)
    stage("writing")
    obj = write_obj(tmp / "garment.obj", mesh, positions=result.x)
    report = {
        "pattern": str(args.pattern),
        "body": str(args.body),
        "garment_id": pattern.garment_id,
        "body_id": pattern.body_id,
        "vertices": int(mesh.n_vertices),
        "triangles": int(len(mesh.triangles)),
        "sewing_pairs": int(len(mesh.sewing_pairs)),
        "edge_length_cm": args.edge_length,
        "method": args.method,
        "device": device,
        "device_choice": device_choice,
        "coarse_start": not args.no_coarse_start,
        "tolerance": args.tolerance,
        "setup_seconds": t_setup,
        **result.report(),
        "dressing": dress,
        "fabric": vars(fabric),
        "settings": {k: v for k, v in vars(settings).items()},
        "sdf": {"dims": list(sdf.values.shape[::-1]), "spacing": sdf.spacing, "origin": sdf.origin.tolist()},
        "files": {"obj": obj.name},
    }
    # Results first, the picture last: a picture that cannot be drawn costs only itself.
    atomic_write_text(tmp / "report.json", json.dumps(report, indent=1) + "\n")
    if args.no_picture:
        report["pictures"] = skipped(["drape.png"])
    else:
        def draw(path):
            from ..sim import render_drape
            render_drape(path, result.x, mesh.triangles, mesh.triangle_panel, body.vertices, body.faces,
                         title=f"{pattern.garment_id or args.pattern.stem} on {args.body.stem}")
        report["pictures"] = draw_pictures(tmp, {"drape.png": draw}, command="drape")
        if report["pictures"]["drape.png"]["written"]:
            report["files"]["picture"] = "drape.png"
    atomic_write_text(tmp / "report.json", json.dumps(report, indent=1) + "\n")
    if console is not None:
        console.close()
    say(f"{'converged' if result.converged else 'NOT converged'}: {result.iterations} iterations, "
        f"{result.seconds:.1f} s, residual {result.residual:.2e}, max seam gap {result.max_sewing_gap_mm:.2f} mm, "
        f"min phi {result.min_phi_mm:.2f} mm -> {out}")
    if not result.converged:
        say(f"seamfit drape: {result.message}; the files are written and report.json says so")
    return 1 if args.fail_unconverged and not result.converged else 0
