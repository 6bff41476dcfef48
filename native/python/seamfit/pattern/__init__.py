"""Sewing patterns: the model, reading and writing (sewpat-1, GarmentCode), validation, SVG."""
from .model import Edge, Panel, Pattern, Placement, Stitch, StitchSide, range_indices
from .sewpat import read_sewpat, write_sewpat

__all__ = ["Edge", "Panel", "Pattern", "Placement", "Stitch", "StitchSide", "range_indices",
           "read_sewpat", "write_sewpat"]
