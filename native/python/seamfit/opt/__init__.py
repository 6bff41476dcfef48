"""Pattern optimization building blocks (Wang 2018, Sections 5-7): the boundary
parametrization, regularizers and preconditioner, the seam-length term (ours), fitting
costs with gradients, deformation transfer, pattern initialization and strength presets.
See docs/optimizer.md."""
from .costs import (POSITIONAL_WEIGHT_BOUNDARY, POSITIONAL_WEIGHT_INTERIOR, STRENGTH_HELP, STRENGTH_NAMES,
                    CostSet, Strengths,
                    positional_weights, sample_sdf)
from .fit import ease_report
from .initialize import InitResult, initialize_pattern
from .parametrization import Parametrization
from .presets import PRESETS, Preset, preset, preset_for_garment
from .regularizers import CORNER_WEIGHT, Regularizers
from .seam import SeamLength, seam_segments
from .sdf_region import body_field
from .size_run import base_place, base_size_label, run_sizes, summary_row
from .transfer import DEFAULT_BANDWIDTH, transfer_garment, vertex_deformation

__all__ = [
    "CORNER_WEIGHT", "CostSet", "DEFAULT_BANDWIDTH", "InitResult", "POSITIONAL_WEIGHT_BOUNDARY",
    "POSITIONAL_WEIGHT_INTERIOR", "PRESETS", "Parametrization", "Preset", "Regularizers", "SeamLength",
    "Strengths", "initialize_pattern", "positional_weights", "preset", "preset_for_garment", "sample_sdf", "seam_segments",
    "transfer_garment", "vertex_deformation",
    "STRENGTH_HELP", "STRENGTH_NAMES", "base_place", "base_size_label", "ease_report",
    "body_field", "run_sizes", "summary_row",
]
