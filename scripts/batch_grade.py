# SPDX-License-Identifier: GPL-3.0-or-later
"""Grade a sewing pattern to a new body without the Blender UI, through the seamfit
extension's operators, and save the result as a .blend next to the files that
`seamfit grade` writes.

Run it either way:

    blender --background --python scripts/batch_grade.py -- PATTERN --base-body B0 --target-body B1 --out DIR
    python scripts/batch_grade.py PATTERN --base-body B0 --target-body B1 --out DIR      (bpy module)

The arguments are those of `seamfit grade`, --method included. PATTERN is a sewpat-1 or
GarmentCode JSON file; B0 and B1 are body meshes (.obj or .ply, metres, Z up, facing -Y).
DIR receives graded.blend (bodies, base pattern, adjusted pattern, draped garment) and seamfit grade's files
(pattern.json, pattern.svg, garment.obj, report.json, and pattern.png and drape.png where matplotlib is
installed). The seamfit extension must be installed in that Blender, or given with
--addon-zip (then it is installed into a temporary folder, not into your Blender).
The folder is written as a set, as `seamfit grade` writes it: a non-empty DIR is replaced
only with --force, never when it holds an input, and a failed or interrupted run leaves it
as it was.
Exit status: 0 results written (report.json says whether the optimization converged; with
--fail-unconverged a run that stopped at its budget exits 1), 2 bad input or failure.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

IN_BLENDER = "bpy" in sys.modules or Path(sys.argv[0]).name.startswith("blender")
# seamfit grade's --method choices (the extension is only importable once it is enabled).
METHODS = ("adjoint", "two-phase", "fixed-point")


def _argv() -> list[str]:
    # Blender passes its own arguments too; ours follow "--".
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1:]
    return [] if IN_BLENDER else sys.argv[1:]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="batch_grade.py", description=__doc__.split("\n\n")[0])
    p.add_argument("pattern", metavar="PATTERN", type=Path, help="base pattern (sewpat-1 or GarmentCode JSON)")
    p.add_argument("--base-body", metavar="B0", type=Path, required=True, help="body the base pattern fits")
    p.add_argument("--target-body", metavar="B1", type=Path, required=True, help="body to grade to")
    p.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if missing)")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="search: adjoint (Algorithm 1, the default) or a baseline for comparison, "
                        "two-phase or fixed-point")
    p.add_argument("--preset", default=None, help="strength preset (dress, fitted, skirt_shirring, pants)")
    for key in ("fix", "cur", "dis", "smo", "str", "pos"):
        p.add_argument(f"--{key}", type=float, default=None, metavar="DELTA", help=f"override the {key} strength")
    p.add_argument("--edge-length", metavar="CM", type=float, default=None, help="mesh edge length (default 1.5)")
    p.add_argument("--sdf-spacing", metavar="M", type=float, default=None, help="body SDF spacing (default 0.0025)")
    p.add_argument("--inner-iterations", "-S", metavar="S", type=int, default=None,
                   help="simulation iterations per outer iteration")
    p.add_argument("--checkpoint-every", "-M", metavar="M", type=int, default=None,
                   help="exact simulation every M outer iterations")
    p.add_argument("--max-iterations", metavar="N", type=int, default=None, help="outer iteration budget")
    p.add_argument("--device", choices=["auto", "cpu", "cuda"], default=None)
    p.add_argument("--no-picture", action="store_true", help="do not write pattern.png and drape.png")
    p.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    p.add_argument("--fail-unconverged", action="store_true",
                   help="exit 1 when the optimization stopped at its budget (the results are still written)")
    p.add_argument("--drape", action="store_true", help="also keep the base garment draped on the base body")
    p.add_argument("--addon-zip", type=Path, default=None,
                   help="install this seamfit extension zip into a temporary folder and use it")
    return p


def fail(msg: str, code: int = 2):
    print(f"batch_grade: error: {msg}", file=sys.stderr)
    sys.exit(code)


def _prepare_blender(addon_zip: Path | None):
    """Import bpy (outside Blender) and make sure the seamfit extension is enabled.
    Returns the extension's module name."""
    if not IN_BLENDER and addon_zip is not None and "BLENDER_USER_RESOURCES" not in os.environ:
        # Keep the temporary install out of the user's Blender configuration.
        os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="seamfit-batch-")
    import bpy
    import addon_utils

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    if addon_zip is not None:
        if not addon_zip.is_file():
            fail(f"{addon_zip}: no such extension zip")
        repo_dir = tempfile.mkdtemp(prefix="seamfit-batch-repo-")
        repos = bpy.context.preferences.extensions.repos
        repo = repos.new(name="seamfit_batch", module="seamfit_batch", custom_directory=repo_dir, source="USER")
        result = bpy.ops.extensions.package_install_files(filepath=str(addon_zip), repo=repo.module,
                                                          enable_on_install=True)
        if result != {"FINISHED"}:
            fail(f"{addon_zip}: the extension did not install")
    enabled = [m for m in bpy.context.preferences.addons.keys() if m.endswith(".seamfit") and m.startswith("bl_ext.")]
    if not enabled:
        installed = [m.__name__ for m in addon_utils.modules() if m.__name__.endswith(".seamfit")
                     and m.__name__.startswith("bl_ext.")]
        if not installed:
            fail("the seamfit extension is not installed in this Blender; install it or pass --addon-zip")
        bpy.ops.preferences.addon_enable(module=installed[0])
        enabled = installed[:1]
    return enabled[0]


def _import_body(path: Path):
    import bpy
    if not path.is_file():
        fail(f"{path}: no such body mesh")
    before = set(bpy.data.objects)
    ext = path.suffix.lower()
    # The bodies are stored Z up in metres: import them without any axis change.
    if ext == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    elif ext == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    else:
        fail(f"{path}: unsupported body file type {ext!r} (.obj or .ply)")
    new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if len(new) != 1:
        fail(f"{path}: expected one mesh, found {len(new)}")
    new[0].name = path.stem      # seamfit names a body after its file, so the results match
    return new[0]


def _apply_settings(s, args, addon) -> None:
    """Scene settings from the arguments; unset ones keep the add-on's defaults, which are
    seamfit grade's defaults."""
    if args.method is not None:
        s.method = addon.methods.from_seamfit(args.method)
    if args.preset:
        try:
            s.strength_preset = args.preset
        except TypeError:
            fail(f"unknown preset {args.preset!r}")
    for key in ("fix", "cur", "dis", "smo", "str", "pos"):
        if getattr(args, key) is not None:
            setattr(s, f"strength_{key}", getattr(args, key))
    if args.edge_length is not None:
        s.edge_length_cm = args.edge_length
    if args.sdf_spacing is not None:
        s.sdf_spacing_mm = 1000.0 * args.sdf_spacing
    if args.inner_iterations is not None:
        s.steps_per_iteration = args.inner_iterations
    if args.checkpoint_every is not None:
        s.exact_every = args.checkpoint_every
    if args.max_iterations is not None:
        s.iterations = args.max_iterations
    if args.device is not None:
        s.device = args.device.upper()


def main() -> int:
    args = build_parser().parse_args(_argv())
    if args.out.exists() and not args.out.is_dir():
        fail(f"{args.out}: exists and is not a folder")
    module = _prepare_blender(args.addon_zip)
    import importlib
    import bpy

    addon = importlib.import_module(module)
    from seamfit.errors import SeamfitError
    from seamfit.output_set import OutputSet
    s = bpy.context.scene.seamfit
    inputs = {"pattern": str(args.pattern), "base_body": str(args.base_body),
              "target_body": str(args.target_body)}
    try:
        # Opened before the grading: a folder that would be refused is refused at once.
        with OutputSet(args.out, inputs=list(inputs.values()), force=args.force) as tmp:
            result = _grade(bpy, addon, s, args)
            try:
                written = addon.compute.write_grade_files(tmp, result, picture=not args.no_picture, inputs=inputs)
            except addon.compute.user_errors() as exc:
                fail(str(exc))
            # Blender writes the .blend next to the target and renames it into place.
            bpy.ops.wm.save_as_mainfile(filepath=str((tmp / "graded.blend").resolve()), check_existing=False,
                                        copy=True)
    except SeamfitError as exc:
        fail(str(exc))
    for path in [*written, tmp / "graded.blend"]:
        print(f"batch_grade: wrote {args.out / path.name}")
    r = result.report
    print(f"batch_grade: {r['method']}: objective {r['objective_initial']:.4g} -> {r['objective_final']:.4g} in "
          f"{r['outer_iterations']} iterations ({r['message']})")
    return 1 if args.fail_unconverged and not result.converged else 0


def _grade(bpy, addon, s, args):
    """Import the inputs into the scene and run the extension's Adjust; its result."""
    try:
        bpy.ops.seamfit.import_pattern(filepath=str(args.pattern))
        s.base_body = _import_body(args.base_body)
        s.target_body = _import_body(args.target_body)
        _apply_settings(s, args, addon)
        if args.drape:
            bpy.ops.seamfit.drape()
        bpy.ops.seamfit.adjust()
    except RuntimeError as exc:       # an operator's error report
        fail(str(exc).removeprefix("Error: ").strip())
    return addon.solve.last_result("adjust")


if __name__ == "__main__":
    code = main()
    if code:
        sys.exit(code)
