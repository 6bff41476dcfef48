"""Sewing patterns: the model, reading and writing (sewpat-1, GarmentCode), validation, SVG,
refitting moved outlines, output checks and grading accuracy against ground truth."""
from .checks import output_checks
from .compare import LandmarkReport, PanelErrors, baseline_errors, change_captured, landmark_errors
from .garmentcode import read_garmentcode
from .io import load_pattern, save_pattern
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide, range_indices
from .refit import RefitResult, refit_pattern
from .sewpat import read_sewpat, write_sewpat
from .svg import write_svg
from .validate import ValidationReport, check_pattern, fix_pattern, validate_pattern

__all__ = ["Edge", "Panel", "Pattern", "Placement", "Stitch", "StitchSide", "range_indices",
           "read_sewpat", "write_sewpat", "read_garmentcode", "load_pattern", "save_pattern",
           "ValidationReport", "validate_pattern", "check_pattern", "fix_pattern", "write_svg",
           "RefitResult", "refit_pattern", "output_checks",
           "LandmarkReport", "PanelErrors", "landmark_errors", "baseline_errors", "change_captured"]
