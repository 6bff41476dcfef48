"""Bodies: mesh input/output, validation, signed distance fields and measurements.

    load_body(path) -> Body                      OBJ / PLY reader (save_body writes)
    validate_body(body) -> BodyReport            errors, warnings, statistics
    check_body(body) -> BodyReport               raises BodyError listing every error
    build_sdf(body, spacing, padding, bounds, cache) -> SignedDistanceField
    body_measurements(body, landmarks=None) -> dict   height and tape girths (cm)
    from_measurements(measurements, gender=None) -> MeasuredBody   a body made to measure
    load_measurement_sets(path) -> [MeasurementSet]  seamfit JSON, Seamly2D .vit / .vst
    hm08_landmarks() -> dict                     measuring landmarks of the sample bodies' mesh
    register_body(scan, template=None) -> Registration   the base mesh fitted onto a mesh of
                                                 another topology (a scan, a character)
"""
from .io import Body, load_body, save_body
from .validate import BodyReport, check_body, checked_body, validate_body
from .sdf import SignedDistanceField, build_sdf, clear_memory_cache
from .measure import MEASUREMENTS, body_measurements, cross_section_girth
from .measurement_sets import MEASUREMENT_UNITS, MeasurementError, MeasurementSet, load_measurement_sets
from .shape_model import hm08_faces, hm08_landmarks
from .made_to_measure import MeasuredBody, from_measurements
from .register import Registration, RegistrationError, check_registrable, register_body, same_topology, target_for, check_frame

__all__ = ["Body", "BodyReport", "MEASUREMENTS", "MeasuredBody", "MeasurementError", "MeasurementSet",
           "Registration", "RegistrationError", "SignedDistanceField", "body_measurements", "build_sdf",
           "check_body", "check_registrable", "cross_section_girth", "from_measurements", "hm08_landmarks",
           "load_body", "load_measurement_sets", "register_body", "save_body", "validate_body",
           "MEASUREMENT_UNITS", "check_frame", "checked_body", "clear_memory_cache", "hm08_faces", "same_topology",
           "target_for"]
