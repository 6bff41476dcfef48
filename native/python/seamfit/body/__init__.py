"""Bodies: mesh input/output, validation, signed distance fields and measurements.

    load_body(path) -> Body                      OBJ / PLY reader (save_body writes)
    validate_body(body) -> BodyReport            errors, warnings, statistics
    check_body(body) -> BodyReport               raises BodyError listing every error
    build_sdf(body, spacing, padding, bounds, cache) -> SignedDistanceField
    body_measurements(body, landmarks=None) -> dict   height and tape girths (cm)
"""
from .io import Body, load_body, save_body
from .validate import BodyReport, check_body, validate_body
from .sdf import SignedDistanceField, build_sdf
from .measure import body_measurements, cross_section_girth

__all__ = ["Body", "BodyReport", "SignedDistanceField", "body_measurements", "build_sdf", "check_body",
           "cross_section_girth", "load_body", "save_body", "validate_body"]
