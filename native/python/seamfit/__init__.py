"""seamfit: rule-free sewing pattern adjustment (grading and made-to-measure).

Public modules: ``seamfit.pattern`` (patterns in and out), ``seamfit.mesh`` (panel
meshing and sewing), ``seamfit.body`` (bodies and signed distance fields).
The compiled core ``seamfit._core`` is loaded lazily through ``seamfit._native``.
"""
from .errors import BodyError, DeviceError, PatternError, SeamfitError, SolveError

__version__ = "0.1.0"
__all__ = ["BodyError", "DeviceError", "PatternError", "SeamfitError", "SolveError", "__version__"]
