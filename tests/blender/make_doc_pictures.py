# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the pictures of docs/blender.md with the bpy module (Cycles on the CPU: no display
or GPU needed). Not a test; run by hand:

    SEAMFIT_ADDON_ZIP=dist/seamfit-0.1.0.zip .venv-blender/bin/python tests/blender/make_doc_pictures.py

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
        bpy.ops.seamfit.drape()
        # Display only: a 2 cm mesh lying 1 mm off the body dips into it between its vertices.
        for obj in bpy.data.collections[f"{coll.name} on {body.name}"].objects:
            obj.modifiers.new("offset", "DISPLACE").strength = 0.004
        _render(scene, "blender_drape.png")



def _emission_material(name, rgba):
    """Flat colour whatever the light: the nest reads like a drawing."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = rgba
    nt.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return mat


def _outline_copy(obj, coll, mat, radius, z):
    """A copy of a panel curve lying flat at the origin, drawn as a tube along its points."""
    cu = obj.data.copy()
    cu.dimensions = "3D"
    cu.fill_mode = "FULL"
    cu.bevel_depth = radius
    cu.materials.clear()
    cu.materials.append(mat)
    copy = bpy.data.objects.new(f"{obj.name} outline", cu)
    copy.location.z = z
    coll.objects.link(copy)
    return copy


def _curve_points(obj):
    sp = obj.data.splines[0]
    co = [0.0] * (4 * len(sp.points))
    sp.points.foreach_get("co", co)
    return [(co[i], co[i + 1]) for i in range(0, len(co), 4)]


def _text(coll, body, size, location, mat, align="CENTER"):
    cu = bpy.data.curves.new(body, "FONT")
    cu.body = body
    cu.size = size
    cu.align_x = align
    cu.align_y = "CENTER"
    cu.materials.append(mat)
    obj = bpy.data.objects.new(body, cu)
    obj.location = location
    coll.objects.link(obj)
    return obj


def _nest(scene, base, graded):
    """Lay the base and graded panel curves out flat, one slot per panel, each copy anchored
    at the middle of its top edge (as seamfit's SVG nest does), rows left to right."""
    nest = bpy.data.collections.new("nest")
    scene.collection.children.link(nest)
    dark = _emission_material("base outline", (0.02, 0.02, 0.02, 1.0))
    orange = _emission_material("graded outline", (0.67, 0.11, 0.0, 1.0))    # #d55e00, the SVG nest's
    grey = _emission_material("label", (0.25, 0.25, 0.25, 1.0))
    key = "seamfit_panel"
    graded_by_panel = {o[key]: o for o in graded.objects if o.type == "CURVE"}
    base_line, graded_line = 0.0030, 0.0018     # base drawn wider, so it shows under the graded
    slots = []      # (panel, [(curve, material, radius, z, anchor)], extent left/bottom/right of the anchor)
    for obj in sorted((o for o in base.objects if o.type == "CURVE"), key=lambda o: o[key]):
        copies, lo_x, lo_y, hi_x = [], 0.0, 0.0, 0.0
        layers = ((obj, dark, base_line, 0.0), (graded_by_panel[obj[key]], orange, graded_line, 0.01))
        for src, mat, radius, z in layers:
            xs, ys = zip(*_curve_points(src))
            anchor = (0.5 * (min(xs) + max(xs)), max(ys))
            copies.append((src, mat, radius, z, anchor))
            lo_x, hi_x = min(lo_x, min(xs) - anchor[0]), max(hi_x, max(xs) - anchor[0])
            lo_y = min(lo_y, min(ys) - anchor[1])
        slots.append((obj[key], copies, (lo_x, lo_y, hi_x)))
    slots.sort(key=lambda s: s[2][1])      # tallest first: the skirt pieces in a row, the waistbands below
    gap, row_width = 0.06, 1.3
    x, y, row_h, width = 0.0, 0.0, 0.0, 0.0
    for name, copies, (lo_x, lo_y, hi_x) in slots:
        w, h = hi_x - lo_x, -lo_y
        if x > 0.0 and x + w > row_width:
            x, y, row_h = 0.0, y - row_h - gap, 0.0
        origin = (x - lo_x, y)
        for src, mat, radius, z, anchor in copies:
            copy = _outline_copy(src, nest, mat, radius, z)
            copy.location.x = origin[0] - anchor[0]
            copy.location.y = origin[1] - anchor[1]
        # A narrow panel (a waistband) gets its name under it, not across its outline.
        label_y = y - 0.5 * h if h > 0.15 else y - h - 0.035
        _text(nest, name, 0.035, (origin[0], label_y, 0.02), grey)
        x += w + gap
        row_h = max(row_h, h)
        width = max(width, x - gap)
    bottom = y - row_h - 0.06      # room for the names under the last row
    # Legend above the sheet.
    for k, (label, mat) in enumerate(((f"base ({scene.seamfit.base_body.name})", dark),
                                      (f"graded ({scene.seamfit.target_body.name})", orange))):
        lx, ly = 0.02 + 0.5 * k * width, 0.09
        stroke = bpy.data.curves.new("legend", "CURVE")
        stroke.dimensions = "3D"
        stroke.bevel_depth = base_line if k == 0 else graded_line
        sp = stroke.splines.new("POLY")
        sp.points.add(1)
        sp.points.foreach_set("co", [lx, ly, 0.0, 1.0, lx + 0.08, ly, 0.0, 1.0])
        stroke.materials.append(mat)
        nest.objects.link(bpy.data.objects.new("legend", stroke))
        _text(nest, label, 0.035, (lx + 0.11, ly, 0.0), grey, align="LEFT")
    return (0.0, bottom, width, 0.12)


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
        obj.hide_render = obj.type != "MESH" or "stretch_color" not in obj.data.color_attributes
    for obj in graded.objects:
        # Display only, as for the drape picture; the 3 cm mesh hugs the thighs, so it needs more.
        if not obj.hide_render:
            obj.modifiers.new("offset", "DISPLACE").strength = 0.008
    _render(scene, "blender_adjust_drape.png")

    for obj in scene.objects:
        obj.hide_render = True
    x0, y0, x1, y1 = _nest(scene, base, graded)
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
