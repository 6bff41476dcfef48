# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the pictures of docs/blender.md with the bpy module (Cycles on the CPU: no display
or GPU needed). Not a test; run by hand:

    SEAMFIT_ADDON_ZIP=dist/seamfit-0.1.0.zip .venv-blender/bin/python tests/blender/make_doc_pictures.py

Writes docs/img/blender_pattern.png (an imported pattern around its body) and, with
--drape, docs/img/blender_drape.png (the draped garment coloured by stretch ratio).
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
        bpy.ops.seamfit.drape()
        # Display only: a 2 cm mesh lying 1 mm off the body dips into it between its vertices.
        for obj in bpy.data.collections[f"{coll.name} on {body.name}"].objects:
            obj.modifiers.new("offset", "DISPLACE").strength = 0.004
        _render(scene, "blender_drape.png")


if __name__ == "__main__":
    main()
