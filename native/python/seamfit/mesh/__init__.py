"""Panel meshing and sewing: a pattern becomes one triangle mesh with sewing pairs.

``build_sewn_mesh(pattern, edge_length_cm=3.0)`` samples every panel boundary so that the two
sides of every stitch get the same number of vertices (``boundary``), triangulates each panel
with gmsh keeping exactly those boundary vertices (``triangulate``), and places the panels in 3D.
``outline_from_uv`` turns new boundary positions back into panel outlines; ``write_obj`` /
``read_obj`` exchange the mesh with Blender. See docs/meshing.md.
"""
from .boundary import DEFAULT_EDGE_LENGTH_CM, PatternBoundary, sample_boundary, validate_for_meshing
from .obj import ObjData, read_obj, read_obj_positions, write_obj
from .sewn_mesh import OutlineMap, SewnMesh, StitchInfo, build_sewn_mesh, outline_from_uv

__all__ = ["DEFAULT_EDGE_LENGTH_CM", "ObjData", "OutlineMap", "PatternBoundary", "SewnMesh", "StitchInfo",
           "build_sewn_mesh", "outline_from_uv", "read_obj", "read_obj_positions", "sample_boundary",
           "validate_for_meshing", "write_obj"]
