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
# editing outlines, DXF sizes and seams sidecars: what the add-on and convert use
from .allowance import ALLOWANCE_CORNERS
from .dxf_sizes import one_size, read_dxf_sizes, write_graded_dxf, write_size_run_dxf
from .edit import arc_through, cubic_through, edges_in_order, edit_edges
from .dxf import flavor_from_path
from .io import read_dxf_size_file, read_pattern_file
from .nest_png import render_nest_png
from .scale import proportional_scale
from .validate import SEAM_TOLERANCE_CM, SEAM_TOLERANCE_REL
from .model import polyline_length
from .points import join_edges, split_edge
from .seams import (apply_sidecar, check_drapable, propose_stitches, sidecar_dict, sidecar_path,
                    write_sidecar)
from .sewpat import pattern_from_dict, pattern_to_dict

__all__ = ["Edge", "Panel", "Pattern", "Placement", "Stitch", "StitchSide", "range_indices",
           "read_sewpat", "write_sewpat", "read_garmentcode", "load_pattern", "save_pattern",
           "ValidationReport", "validate_pattern", "check_pattern", "fix_pattern", "write_svg",
           "RefitResult", "refit_pattern", "output_checks",
           "LandmarkReport", "PanelErrors", "landmark_errors", "baseline_errors", "change_captured",
           "ALLOWANCE_CORNERS", "one_size", "read_dxf_sizes", "write_graded_dxf", "write_size_run_dxf",
           "arc_through", "cubic_through", "edges_in_order", "edit_edges", "read_dxf_size_file",
           "polyline_length", "join_edges", "split_edge", "apply_sidecar", "check_drapable",
           "propose_stitches", "sidecar_dict", "sidecar_path", "write_sidecar", "pattern_from_dict",
           "pattern_to_dict", "flavor_from_path", "read_pattern_file", "render_nest_png", "proportional_scale",
           "SEAM_TOLERANCE_CM", "SEAM_TOLERANCE_REL"]
