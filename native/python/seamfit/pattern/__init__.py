"""Sewing patterns: the model, reading and writing (sewpat-1, GarmentCode), validation, SVG."""
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide, range_indices

__all__ = ["Edge", "Panel", "Pattern", "Placement", "Stitch", "StitchSide", "range_indices"]
