# SPDX-License-Identifier: GPL-3.0-or-later
"""Grade a sewing pattern to a new body without the Blender UI, through the seamfit
extension's operators, and save the result as a .blend next to the files that
`seamfit grade` writes.

Run it with Blender's Python, either way:

    blender --background --python scripts/batch_grade.py -- PATTERN --base-body B0 --target-body B1 --out DIR
    python scripts/batch_grade.py PATTERN --base-body B0 --target-body B1 --out DIR      (a Python with bpy)

It takes every option of `seamfit grade` (the same definition: the installed seamfit's), plus
--addon-zip ZIP (install that extension into a temporary folder, removed afterwards, instead
of using the one installed in this Blender) and --drape (also keep the base garment draped on
the base body). DIR receives graded.blend (bodies, base pattern, adjusted pattern, draped
garment) and seamfit grade's files (pattern.json, pattern.svg, garment.obj, report.json, and
pattern.png and drape.png where matplotlib is installed), written as a set: a non-empty DIR
is replaced only with --force, never when it holds an input, and a failed or interrupted run
leaves it as it was.

Exit status, as `seamfit grade`'s: 0 results written (report.json says whether the search
converged), 1 stopped at its budget with --fail-unconverged (results written), 2 unusable
input or options, or no Blender Python, 3 internal error, 130 interrupted.
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

PROG = "batch_grade.py"
HOW_TO_RUN = ("it needs Blender's Python: run `blender --background --python scripts/batch_grade.py -- ARGS`, "
              "or this script with a Python that has the bpy module (pip install bpy)")
# The options the add-on's scene settings hold; the others go to its further grading settings.
_SCENE_OPTIONS = {"method", "preset", "fix", "cur", "dis", "smo", "str", "pos", "seam", "edge_length",
                  "sdf_spacing", "inner_iterations", "checkpoint_every", "max_iterations", "device"}
_temporary: list[str] = []
_quiet = False


class Failed(Exception):
    """A one-line error for the user, and the exit status."""

    def __init__(self, message: str, code: int = 2):
        super().__init__(message)
        self.code = code


def _argv() -> list[str]:
    # Blender passes its own arguments too; ours follow "--".
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1:]
    in_blender = "bpy" in sys.modules and Path(sys.argv[0]).name.startswith("blender")
    return [] if in_blender else sys.argv[1:]


def say(message: str) -> None:
    if not _quiet:
        print(f"batch_grade: {message}")


def _prefix_options(argv: list[str]):
    """--addon-zip, --drape and -q/--quiet, known before seamfit (and so the full parser) is there."""
    import argparse
    pre = argparse.ArgumentParser(add_help=False)
    pre.add_argument("--addon-zip", type=Path, default=None)
    pre.add_argument("--drape", action="store_true")
    pre.add_argument("-q", "--quiet", action="store_true")
    pre.add_argument("-h", "--help", action="store_true")
    return pre.parse_known_args(argv)[0]


def build_parser():
    """seamfit grade's own parser (from the installed seamfit), with this script's name and
    its two options added."""
    from seamfit.commands import grade_parser
    p = grade_parser(PROG)
    p.description = __doc__.split("\n\n")[0] + ". The options are those of seamfit grade, plus --addon-zip and --drape."
    p.add_argument("--addon-zip", type=Path, default=None, metavar="ZIP",
                   help="install this seamfit extension zip into a temporary folder (removed afterwards) and use it")
    p.add_argument("--drape", action="store_true", help="also keep the base garment draped on the base body")
    return p


def _temp_folder(prefix: str) -> str:
    path = tempfile.mkdtemp(prefix=prefix)
    _temporary.append(path)
    return path


def _cleanup() -> None:
    """The temporary Blender folders (the installed extension: about 280 MB) go with the run."""
    while _temporary:
        shutil.rmtree(_temporary.pop(), ignore_errors=True)


def _prepare_blender(addon_zip: Path | None):
    """Import bpy (outside Blender) and make sure the seamfit extension is enabled.
    Returns the extension's module name."""
    if addon_zip is not None:
        if not addon_zip.is_file():
            raise Failed(f"{addon_zip}: no such extension zip")
        if "bpy" not in sys.modules and "BLENDER_USER_RESOURCES" not in os.environ:
            # Keep the temporary install out of the user's Blender configuration.
            os.environ["BLENDER_USER_RESOURCES"] = _temp_folder("seamfit-batch-")
        # A temporary install: seamfit's disk cache stays where the command line keeps it.
        os.environ.setdefault("SEAMFIT_CACHE_DIR", str(Path.home() / ".cache" / "seamfit"))
    try:
        import bpy
    except ImportError:
        raise Failed(HOW_TO_RUN) from None
    import addon_utils

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    if addon_zip is not None:
        repo_dir = _temp_folder("seamfit-batch-repo-")
        repos = bpy.context.preferences.extensions.repos
        repo = repos.new(name="seamfit_batch", module="seamfit_batch", custom_directory=repo_dir, source="USER")
        result = bpy.ops.extensions.package_install_files(filepath=str(addon_zip), repo=repo.module,
                                                          enable_on_install=True)
        if result != {"FINISHED"}:
            raise Failed(f"{addon_zip}: the extension did not install")
    enabled = [m for m in bpy.context.preferences.addons.keys() if m.endswith(".seamfit") and m.startswith("bl_ext.")]
    if not enabled:
        installed = [m.__name__ for m in addon_utils.modules() if m.__name__.endswith(".seamfit")
                     and m.__name__.startswith("bl_ext.")]
        if not installed:
            raise Failed("the seamfit extension is not installed in this Blender; install it or pass --addon-zip")
        bpy.ops.preferences.addon_enable(module=installed[0])
        enabled = installed[:1]
    return enabled[0]


def _import_body(path: Path):
    import bpy
    if not path.is_file():
        raise Failed(f"{path}: no such body mesh")
    before = set(bpy.data.objects)
    ext = path.suffix.lower()
    # The bodies are stored Z up in metres: import them without any axis change.
    if ext == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    elif ext == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    else:
        raise Failed(f"{path}: unsupported body file type {ext!r} (.obj or .ply)")
    new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if len(new) != 1:
        raise Failed(f"{path}: expected one mesh, found {len(new)}")
    new[0].name = path.stem      # seamfit names a body after its file, so the results match
    return new[0]


def _apply_settings(s, args, addon) -> None:
    """Scene settings from the arguments (whose defaults are seamfit grade's, as the add-on's)."""
    import json
    s.method = addon.methods.from_seamfit(args.method)
    if args.preset != "auto":       # auto: the import picked the preset for the garment's kind
        s.strength_preset = args.preset
    for key in addon.presets.STRENGTH_KEYS:
        if getattr(args, key) is not None:
            setattr(s, f"strength_{key}", getattr(args, key))
    # Every other grading setting: on its scene property where the add-on shows it, else
    # (when not the default) in More grading settings.
    from seamfit import settings
    extra = {}
    for st in settings.for_command("batch"):
        if st.owner != "grade" or st.name in ("method", "preset"):
            continue
        value = getattr(args, st.dest)
        if st.addon is not None:
            setattr(s, st.addon.prop, settings.to_blender(f"grade.{st.name}", value))
        elif value != st.default:
            extra[st.name] = value
    s.grade_options = json.dumps(extra) if extra else ""


def _check_options(args) -> None:
    """The command line's own checks of its numbers, before anything else is imported."""
    from seamfit.commands import check_grade_numbers
    check_grade_numbers(args)


def _accuracy(args, result) -> dict | None:
    """With --truth: the landmark errors `seamfit grade --truth` reports."""
    if args.truth is None:
        return None
    from seamfit.pattern import baseline_errors, landmark_errors, load_pattern
    truth = load_pattern(args.truth)
    base = load_pattern(args.pattern)
    return {"truth": str(args.truth), "graded": landmark_errors(result.result.pattern, truth).to_dict(),
            "base_unchanged": baseline_errors(base, truth).to_dict()}


def run(argv: list[str]) -> int:
    global _quiet
    pre = _prefix_options(argv)
    _quiet = pre.quiet
    if pre.help and "bpy" not in sys.modules:
        try:
            import bpy  # noqa: F401
        except ImportError:
            print(__doc__)
            return 0
    module = _prepare_blender(pre.addon_zip)
    args = build_parser().parse_args(argv)
    if args.out.exists() and not args.out.is_dir():
        raise Failed(f"{args.out}: exists and is not a folder")
    import importlib
    import bpy

    addon = importlib.import_module(module)
    from seamfit.errors import SeamfitError
    from seamfit.output_set import OutputSet
    s = bpy.context.scene.seamfit
    inputs = {"pattern": str(args.pattern), "base_body": str(args.base_body),
              "target_body": str(args.target_body)}
    try:
        _check_options(args)
        # Opened before the grading: a folder that would be refused is refused at once.
        with OutputSet(args.out, inputs=[*inputs.values(), args.truth], force=args.force) as tmp:
            result = _grade(bpy, addon, s, args)
            extra = _accuracy(args, result)
            written = addon.compute.write_grade_files(tmp, result, picture=not args.no_picture, inputs=inputs,
                                                      extra=None if extra is None else {"accuracy": extra})
            # Blender writes the .blend next to the target and renames it into place.
            bpy.ops.wm.save_as_mainfile(filepath=str((tmp / "graded.blend").resolve()), check_existing=False,
                                        copy=True)
    except (SeamfitError, *addon.compute.user_errors()) as exc:
        raise Failed(str(exc)) from None
    for path in [*written, tmp / "graded.blend"]:
        say(f"wrote {args.out / path.name}")
    r = result.report
    say(f"{r['method']}: objective {r['objective_initial']:.4g} -> {r['objective_final']:.4g} in "
        f"{r['outer_iterations']} iterations ({r['message']})")
    for w in result.warnings:
        print(f"batch_grade: warning: {w}", file=sys.stderr)
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
        raise Failed(str(exc).removeprefix("Error: ").strip()) from None
    return addon.solve.last_result("adjust")


def main() -> int:
    try:
        return run(_argv())
    except Failed as exc:
        print(f"batch_grade: error: {exc}", file=sys.stderr)
        return exc.code
    except KeyboardInterrupt:
        print("batch_grade: interrupted (SIGINT)", file=sys.stderr)
        return 130
    except SystemExit as exc:       # argparse: --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    except Exception as exc:
        if os.environ.get("SEAMFIT_TRACEBACK") == "1":
            raise
        print(f"batch_grade: internal error: {exc!r} (run with SEAMFIT_TRACEBACK=1 for the traceback)",
              file=sys.stderr)
        return 3
    finally:
        _cleanup()


if __name__ == "__main__":
    code = main()
    if code:        # in Blender, exiting with 0 here would also skip its later command-line arguments
        sys.exit(code)
