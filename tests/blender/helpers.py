# SPDX-License-Identifier: GPL-3.0-or-later
"""Helpers for the bpy tests: sample files, scene fingerprints, undo."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import bpy
import numpy as np

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sample_files"
PENCIL = SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json"
PENCIL_GC_SPEC = SAMPLES / "patterns" / "gc_pencil_skirt" / "size06" / "native" / "gc_pencil_skirt_specification.json"
BODICE = SAMPLES / "patterns" / "fs_bodice" / "size06" / "pattern.json"
BODY_BASE = SAMPLES / "bodies" / "women_size06.obj"
BODY_TARGET = SAMPLES / "bodies" / "women_size10.obj"
MODULE = "bl_ext.user_default.seamfit"
# Valentina's DXF exports of shared patterns (read-only; no seams sidecar beside them).
DXF_DIR = Path(os.environ.get("SEAMFIT_SHARED_DATA", REPO.parent / "shared" / "data")) / "dxf"
KEIKO = DXF_DIR / "Keiko_skirt.aama.dxf"

# A coarse, short grading (seconds), the same for the add-on, the command line and the batch script.
GRADE_EDGE_CM, GRADE_SDF_M, GRADE_OUTER, GRADE_EVERY = 4.0, 0.005, 8, 4
GRADE_ARGS = ["--edge-length", str(GRADE_EDGE_CM), "--sdf-spacing", str(GRADE_SDF_M),
              "--max-iterations", str(GRADE_OUTER), "--checkpoint-every", str(GRADE_EVERY)]


def addon():
    """The enabled extension's package (its modules: compute, scene_io, jobs, ...)."""
    import importlib
    return importlib.import_module(MODULE)


def file_digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def object_fingerprint(obj) -> tuple:
    """Name, transform and geometry of an object, to prove it was not modified."""
    data = ()
    if obj.type == "MESH":
        co = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", co)
        data = (len(obj.data.polygons), hashlib.sha1(co.tobytes()).hexdigest())
    elif obj.type == "CURVE":
        parts = []
        for sp in obj.data.splines:
            for pts, attrs in ((sp.points, ("co",)), (sp.bezier_points, ("co", "handle_left", "handle_right"))):
                for attr in attrs:
                    co = np.empty(len(pts) * len(getattr(pts[0], attr)) if len(pts) else 0)
                    pts.foreach_get(attr, co)
                    parts.append(hashlib.sha1(co.tobytes()).hexdigest())
        data = tuple(parts)
    m = tuple(round(v, 9) for row in obj.matrix_world for v in row)
    return (obj.name, obj.type, m, data, tuple(sorted(c.name for c in obj.users_collection)))


def scene_fingerprint() -> dict:
    return {
        "objects": sorted(object_fingerprint(o) for o in bpy.data.objects),
        "collections": sorted((c.name, tuple(sorted(o.name for o in c.objects))) for c in bpy.data.collections),
        "meshes": sorted(m.name for m in bpy.data.meshes),
        "curves": sorted(c.name for c in bpy.data.curves),
        "materials": sorted(m.name for m in bpy.data.materials),
    }


def datablock_counts() -> dict:
    return {k: len(getattr(bpy.data, k)) for k in ("collections", "objects", "meshes", "curves", "materials")}


def import_obj(path: Path, name: str):
    """Import an OBJ body as it comes (Z up, metres), the way a user would."""
    before = set(bpy.data.objects)
    bpy.ops.wm.obj_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    new = [o for o in bpy.data.objects if o not in before]
    assert len(new) == 1
    new[0].name = name
    return new[0]


def scene_for(scene, edge_length_cm: float, sdf_spacing_mm: float, pattern: Path = PENCIL, target: bool = False):
    """``pattern`` imported and the base body (with ``target``, the target body too) set,
    at this mesh and body-field resolution: the scene settings, ready for Drape."""
    bpy.ops.seamfit.import_pattern(filepath=str(pattern))
    s = scene.seamfit
    s.base_body = import_obj(BODY_BASE, "women_size06")
    if target:
        s.target_body = import_obj(BODY_TARGET, "women_size10")
    s.edge_length_cm = edge_length_cm
    s.sdf_spacing_mm = sdf_spacing_mm
    return s


def grading_scene_for(scene, pattern: Path = PENCIL):
    """scene_for at the coarse grading of GRADE_ARGS, both bodies set: ready for Adjust."""
    s = scene_for(scene, GRADE_EDGE_CM, 1000 * GRADE_SDF_M, pattern, target=True)
    s.iterations = GRADE_OUTER
    s.exact_every = GRADE_EVERY
    return s


def window_override():
    w = bpy.context.window_manager.windows[0]
    return bpy.context.temp_override(window=w, screen=w.screen, area=w.screen.areas[0])


def undo_push(message: str) -> None:
    with window_override():
        bpy.ops.ed.undo_push(message=message)


def undo() -> None:
    with window_override():
        bpy.ops.ed.undo()


def extension_site_packages() -> Path:
    """Where Blender unpacked the extension's wheels."""
    import sys
    (site,) = [p for p in sys.path if p.endswith("site-packages") and "extensions" in p]
    return Path(site)


def bezier_world(obj, attr: str = "co") -> np.ndarray:
    """The curve points (or handles) of a panel's Bezier curve, in world metres."""
    bp = obj.data.splines[0].bezier_points
    co = np.empty(len(bp) * 3)
    bp.foreach_get(attr, co)
    m = np.array(obj.matrix_world)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
