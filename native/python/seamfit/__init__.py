"""seamfit: rule-free sewing pattern adjustment (grading and made-to-measure).

What a script uses, importable from ``seamfit`` itself (each loads its module on first use,
so ``import seamfit`` stays light):

    pattern = seamfit.load_pattern("skirt.json")            # sewpat-1, GarmentCode JSON, DXF
    base, target = seamfit.load_body("size06.obj"), seamfit.load_body("size10.obj")
    result = seamfit.grade(pattern, base, target, seamfit.GradeSettings())
    seamfit.save_pattern(result.pattern, "skirt_size10.json")

The modules behind them: ``seamfit.pattern`` (patterns in and out, checks, comparison),
``seamfit.body`` (bodies, measurements, distance fields), ``seamfit.mesh`` (panel meshing
and sewing), ``seamfit.sim`` (the drape), ``seamfit.opt`` (grading) and ``seamfit.settings``
(every setting's one declaration), with ``PUBLIC_MODULES`` the rest of the public face: each
exports what it offers in ``__all__``, and modules below them are the implementation's. The
compiled core ``seamfit._core`` is loaded lazily
through ``seamfit._native``.
"""
from importlib import import_module

from .errors import BodyError, DeviceError, PatternError, SeamfitError, SolveError

__version__ = "0.1.0"

# public name -> the module that defines it
_API = {
    # patterns
    "Pattern": "seamfit.pattern", "load_pattern": "seamfit.pattern", "save_pattern": "seamfit.pattern",
    "check_pattern": "seamfit.pattern", "write_svg": "seamfit.pattern",
    # bodies
    "Body": "seamfit.body", "load_body": "seamfit.body", "save_body": "seamfit.body",
    "from_measurements": "seamfit.body", "body_measurements": "seamfit.body", "register_body": "seamfit.body",
    # meshing and the drape
    "build_sewn_mesh": "seamfit.mesh", "Simulator": "seamfit.sim", "Fabric": "seamfit.sim",
    "SimSettings": "seamfit.sim",
    # grading
    "GradeSettings": "seamfit.opt.grade", "GradeResult": "seamfit.opt.grade", "grade": "seamfit.opt.grade",
    "run_sizes": "seamfit.opt.size_run",
    # the files of a grading, and a pattern's own file, as every front end writes them
    "write_grade_files": "seamfit.grade_files", "write_pattern_files": "seamfit.pattern_files",
    # comparing with a drafted pattern
    "landmark_errors": "seamfit.pattern", "baseline_errors": "seamfit.pattern",
}

# The modules a front end (the add-on, the batch script) may use, each through its
# ``__all__``; everything below them is the implementation's and may change.
PUBLIC_MODULES = ("pattern", "body", "mesh", "sim", "opt", "settings", "errors", "device", "progress", "cache",
                  "output_set", "grade_files", "pattern_files", "commands")

__all__ = ["BodyError", "DeviceError", "PatternError", "SeamfitError", "SolveError", "PUBLIC_MODULES", "__version__", *_API]


def __getattr__(name: str):
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'seamfit' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value         # the next lookup is a plain attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(_API))
