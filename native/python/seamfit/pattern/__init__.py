"""Sewing patterns: the model, reading and writing (sewpat-1, GarmentCode), validation, SVG."""
from .garmentcode import read_garmentcode
from .io import load_pattern, save_pattern
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide, range_indices
from .sewpat import read_sewpat, write_sewpat
from .svg import write_svg
from .validate import ValidationReport, check_pattern, fix_pattern, validate_pattern

__all__ = ["Edge", "Panel", "Pattern", "Placement", "Stitch", "StitchSide", "range_indices",
           "read_sewpat", "write_sewpat", "read_garmentcode", "load_pattern", "save_pattern",
           "ValidationReport", "validate_pattern", "check_pattern", "fix_pattern", "write_svg"]
