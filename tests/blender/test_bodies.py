# SPDX-License-Identifier: GPL-3.0-or-later
"""Bodies picked from scene meshes: checked and measured by seamfit."""
import bpy
import numpy as np
import pytest

from helpers import BODY_BASE, BODY_TARGET, import_obj, object_fingerprint


def test_obj_import_keeps_body_coordinates(scene):
    from seamfit.body import load_body
    obj = import_obj(BODY_BASE, "base")
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    world = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    assert np.allclose(world, load_body(BODY_BASE).vertices, atol=1e-6)


def test_check_bodies_measures_like_seamfit(scene):
    from seamfit.body import body_measurements, load_body
    s = scene.seamfit
    s.base_body = import_obj(BODY_BASE, "base")
    s.target_body = import_obj(BODY_TARGET, "target")
    before = [object_fingerprint(o) for o in (s.base_body, s.target_body)]
    assert bpy.ops.seamfit.check_bodies() == {"FINISHED"}
    for rep, path in ((s.base_report, BODY_BASE), (s.target_report, BODY_TARGET)):
        want = body_measurements(load_body(path))
        assert rep.checked and rep.ok, rep.message
        for key in ("height", "bust", "waist", "hip"):
            # The scene mesh is float32: girths agree to well under a millimetre.
            assert getattr(rep, key) == pytest.approx(want[key], abs=0.05), key
    assert s.target_report.hip > s.base_report.hip
    assert [object_fingerprint(o) for o in (s.base_body, s.target_body)] == before


def test_body_transform_and_modifiers_are_applied(scene):
    """The body is read as it shows: moved 1 m up, it is still the same height."""
    s = scene.seamfit
    s.base_body = import_obj(BODY_BASE, "base")
    bpy.ops.seamfit.check_bodies()
    height = s.base_report.height
    s.base_body.location.z = 1.0
    s.base_body.scale = (1.1, 1.1, 1.1)
    bpy.ops.seamfit.check_bodies()
    assert s.base_report.height == pytest.approx(1.1 * height, rel=1e-4)


def test_a_broken_body_gets_a_clear_message(scene):
    s = scene.seamfit
    bpy.ops.mesh.primitive_plane_add(size=0.5)
    s.base_body = bpy.context.active_object
    with pytest.raises(RuntimeError, match="base body 'Plane'"):
        bpy.ops.seamfit.check_bodies()
    assert s.base_report.checked and not s.base_report.ok
    assert s.base_report.message
