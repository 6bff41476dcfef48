# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the pictures of docs/blender.md with the bpy module (Cycles on the CPU: no display
or GPU needed). Not a test; run by hand:

    SEAMFIT_ADDON_ZIP=dist/seamfit-0.1.0.zip .venv-blender-5.0.1/bin/python tests/blender/make_doc_pictures.py

Writes docs/img/blender_pattern.png (an imported pattern around its body) and, with
--drape, docs/img/blender_drape.png (the draped garment coloured by stretch ratio).

With --adjust it renders only the grading walkthrough's pictures (a coarse, short grading
of the pencil skirt from women_size06 to women_size10 through Adjust Pattern):
docs/img/blender_adjust_drape.png (the graded garment on the target body, coloured by
stretch) and docs/img/blender_adjust_curves.png (the new panel curves over the base
pattern's, seen from above like a grading nest).
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="seamfit-doc-"))

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "docs" / "img"
PATTERN = REPO / "sample_files" / "patterns" / "gc_pencil_skirt" / "size06" / "pattern.json"
BODY = REPO / "sample_files" / "bodies" / "women_size06.obj"
TARGET = REPO / "sample_files" / "bodies" / "women_size10.obj"


def _setup_scene():
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.extensions.package_install_files(filepath=os.environ["SEAMFIT_ADDON_ZIP"], repo="user_default",
                                             enable_on_install=True)
    bpy.ops.wm.obj_import(filepath=str(BODY), forward_axis="Y", up_axis="Z")
    body = bpy.context.selected_objects[0]
    scene = bpy.context.scene
    scene.seamfit.base_body = body
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = (1.9, -1.9, 1.25)
    cam.rotation_euler = (Vector((0.0, 0.0, 0.85)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.7, 0.2, 0.5)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("world")
    scene.world = world
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs[0].default_value = (0.85, 0.85, 0.87, 1.0)
    bg.inputs[1].default_value = 0.6
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 24
    scene.cycles.device = "CPU"
    scene.render.resolution_x, scene.render.resolution_y = 480, 600
    return scene, body


def _object_colour_material():
    mat = bpy.data.materials.new("panel colour")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    info = nt.nodes.new("ShaderNodeObjectInfo")
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    nt.links.new(info.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def _flat_material(rgba):
    mat = bpy.data.materials.new("stitch colour")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED").inputs["Base Color"].default_value = rgba
    return mat


def _render(scene, name):
    OUT.mkdir(parents=True, exist_ok=True)
    scene.render.filepath = str(OUT / name)
    bpy.ops.render.render(write_still=True)
    print("wrote", OUT / name)


def main():
    if "--adjust" in sys.argv:
        adjust_pictures()
        return
    scene, body = _setup_scene()
    body.data.materials.append(_flat_material((0.35, 0.37, 0.42, 1.0)))    # the garment shows against it
    bpy.ops.seamfit.import_pattern(filepath=str(PATTERN))
    coll = scene.seamfit.pattern
    mat = _object_colour_material()
    tubes = None
    for obj in coll.objects:
        if obj.type == "CURVE":
            obj.data.materials.append(mat)
        else:   # stitches: a copy as thin tubes, so the loose edges show in a render
            tube = bpy.data.objects.new("stitch tubes", obj.data.copy())
            scene.collection.objects.link(tube)
            bpy.context.view_layer.objects.active = tube
            tube.select_set(True)
            bpy.ops.object.convert(target="CURVE")
            tube.data.bevel_depth = 0.002
            tube.data.materials.append(_flat_material((0.8, 0.1, 0.1, 1.0)))
            tubes = tube
    _render(scene, "blender_pattern.png")
    if "--drape" in sys.argv:
        coll.hide_render = True
        tubes.hide_render = True
        scene.seamfit.edge_length_cm = 2.0
        bpy.ops.seamfit.drape()     # drawn as the extension draws it: outside the body, with its legend
        _render(scene, "blender_drape.png")



def _emission_material(name, rgba):
    """Flat colour whatever the light: the compare view reads like a drawing."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = rgba
    nt.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return mat


def adjust_pictures():
    scene, base_body = _setup_scene()
    base_body.hide_render = True
    bpy.ops.wm.obj_import(filepath=str(TARGET), forward_axis="Y", up_axis="Z")
    target = bpy.context.selected_objects[0]
    target.data.materials.append(_flat_material((0.35, 0.37, 0.42, 1.0)))
    bpy.ops.seamfit.import_pattern(filepath=str(PATTERN))
    s = scene.seamfit
    base = s.pattern
    s.target_body = target
    # Coarse and short: a picture of what Adjust Pattern writes, not a converged grading.
    s.edge_length_cm = 3.0
    s.sdf_spacing_mm = 5.0
    s.iterations = 16
    s.exact_every = 4
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    graded = next(c for c in bpy.data.collections if c.seamfit.role == "graded")
    print(f"graded {graded.name}: objective {graded.seamfit.objective:.4g}, "
          f"{graded.seamfit.iterations} iterations, hip ease {graded.seamfit.fit.hip:+.1f} cm")
    for obj in list(base.objects) + list(graded.objects):
        # The garment and its legend; the panel curves around the body would hide it.
        obj.hide_render = obj.type == "CURVE" and "seamfit_panel" in obj
        if obj.type == "MESH" and "stitch" in obj.data.attributes and "panel" not in obj.data.attributes:
            obj.hide_render = True
    _render(scene, "blender_adjust_drape.png")

    for obj in scene.objects:
        obj.hide_render = True
    # The extension's compare view: each graded panel over its base, aligned at the top middle.
    assert bpy.ops.seamfit.compare(collection=graded.name, layout="OVERLAY") == {"FINISHED"}
    view = next(c for c in bpy.data.collections if c.seamfit.role == "compare")
    base_copy, graded_copy = sorted(view.children, key=lambda c: c.name)
    dark = _emission_material("base outline", (0.02, 0.02, 0.02, 1.0))
    orange = _emission_material("graded outline", (0.67, 0.11, 0.0, 1.0))    # #d55e00, the SVG nest's
    for copy, mat in ((base_copy, dark), (graded_copy, orange)):
        for obj in copy.objects:
            obj.hide_render = False
            obj.data.materials.append(mat)
    x0, y0, x1, y1 = view["seamfit_sheet"]
    y1 += 0.05
    cam = scene.camera
    cam.hide_render = False
    cam.data.type = "ORTHO"
    margin = 0.05
    w, h = x1 - x0 + 2 * margin, y1 - y0 + 2 * margin
    cam.data.ortho_scale = max(w, h)
    cam.location = (0.5 * (x0 + x1), 0.5 * (y0 + y1), 2.0)
    cam.rotation_euler = (0.0, 0.0, 0.0)
    scene.render.resolution_x = 720
    scene.render.resolution_y = round(720 * h / w)
    scene.world.node_tree.nodes["Background"].inputs[0].default_value = (1.0, 1.0, 1.0, 1.0)
    scene.world.node_tree.nodes["Background"].inputs[1].default_value = 1.0
    scene.view_settings.view_transform = "Standard"     # white stays white
    scene.cycles.samples = 8
    _render(scene, "blender_adjust_curves.png")


if __name__ == "__main__":
    main()
