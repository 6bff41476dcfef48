# SPDX-License-Identifier: GPL-3.0-or-later
"""Bodies made for grading in Blender: a body from measurements (cm, inches, a size
chart's sizes), a Y-up body refused by Check Bodies with the fix, and a target of another
mesh registered onto the base body's mesh."""
import bpy
import numpy as np
import pytest

from helpers import BODY_BASE, GRADE_EDGE_CM, GRADE_SDF_M, PENCIL, SAMPLES, addon, import_obj, object_fingerprint

CHART = SAMPLES / "measurements" / "size_chart.vst"


def _measured(obj) -> dict:
    """seamfit's measurements of the object as the scene holds it (float32, world)."""
    from seamfit.body import Body, body_measurements, hm08_landmarks
    body = addon().operators.capture_body(obj, bpy.context.evaluated_depsgraph_get())
    return body_measurements(Body(body.vertices, body.triangles, name=obj.name), hm08_landmarks())


def _new_objects(before):
    return [o for o in bpy.data.objects if o not in before]


def test_body_from_measurements_meets_them(scene):
    s = scene.seamfit
    user = import_obj(BODY_BASE, "women_size06")
    user_before = object_fingerprint(user)
    m = s.measure
    want = {"height": 170.0, "bust": 92.0, "waist": 72.0, "hip": 100.0}
    for key, value in want.items():
        setattr(m, f"m_{key}", value)
    m.body_name = "ann"
    before = set(bpy.data.objects)
    assert bpy.ops.seamfit.body_from_measurements() == {"FINISHED"}
    (obj,) = _new_objects(before)
    assert obj.name == "ann" and s.target_body == obj
    measured = _measured(obj)
    for key, value in want.items():
        assert measured[key] == pytest.approx(value, abs=0.5), key
    # The measurements travel with the object: requested, achieved, which were inferred.
    assert obj["seamfit_requested_cm"].to_dict() == pytest.approx(want)
    achieved = obj["seamfit_achieved_cm"].to_dict()
    assert set(achieved) == set(addon().props.MEASUREMENTS)
    for key in want:
        assert achieved[key] == pytest.approx(measured[key], abs=0.05)
    inferred = obj["seamfit_inferred"].split(", ")
    assert "inseam" in inferred and "waist" not in inferred and len(inferred) == 8
    assert object_fingerprint(user) == user_before
    # The panel shows the active made body's measurements.
    from test_ui import Recorder
    bpy.context.view_layer.objects.active = obj
    log = []
    bpy.types.SEAMFIT_PT_measure.draw(type("P", (), {"layout": Recorder(log)})(), bpy.context)
    labels = [e[1] for e in log if e[0] == "label"]
    assert "Waist: 72.0 / 72.0" in labels and any(t.startswith("Inseam: inferred / ") for t in labels)


def test_inches_and_size_chart(scene):
    m = scene.seamfit.measure
    m.m_waist = 70.0
    m.units = "IN"
    assert m.m_waist == pytest.approx(70.0 / 2.54, rel=1e-6)
    m.units = "CM"
    assert m.m_waist == pytest.approx(70.0, rel=1e-6)
    m.units = "IN"
    assert bpy.ops.seamfit.load_size_chart(filepath=str(CHART)) == {"FINISHED"}
    from seamfit.body import load_measurement_sets
    sizes = {s.name: s.cm for s in load_measurement_sets(CHART)}
    assert [s.name for s in m.chart_sizes] == list(sizes)
    m.size = "2"                                  # size42: the fields show its values in inches
    want = sizes["size42"]
    assert m.m_hip == pytest.approx(want["hip"] / 2.54, rel=1e-6)
    assert m.m_thigh == 0.0 and m.body_name == "size42"
    before = set(bpy.data.objects)
    assert bpy.ops.seamfit.body_from_measurements() == {"FINISHED"}
    (obj,) = _new_objects(before)
    assert obj["seamfit_requested_cm"].to_dict() == pytest.approx(want, abs=1e-3)
    measured = _measured(obj)
    for key, value in want.items():
        assert measured[key] == pytest.approx(value, abs=0.5), key
    # seamfit's JSON size chart (the sample bodies' measurements.json) gives presets too.
    assert bpy.ops.seamfit.load_size_chart(filepath=str(SAMPLES / "bodies" / "measurements.json")) == {"FINISHED"}
    names = [s.name for s in m.chart_sizes]
    assert names[0] == "women_size02" and "men_medium" in names and m.body_name == "women_size02"
    m.size = str(names.index("men_medium"))
    assert m.gender == "male" and m.m_height == pytest.approx(178.0 / 2.54, rel=1e-6)


def test_bad_measurement_is_one_line(scene):
    m = scene.seamfit.measure
    m.m_hip = 960.0                              # millimetres typed as cm
    before = set(bpy.data.objects)
    with pytest.raises(RuntimeError, match=r"hip = 960 cm is outside 60-180 cm.*units") as err:
        bpy.ops.seamfit.body_from_measurements()
    assert "Traceback" not in str(err.value)
    assert not _new_objects(before)


def test_y_up_body_is_refused_with_the_fix(scene):
    """Blender's OBJ importer lays a Z-up body on its back by default (Up axis Y)."""
    s = scene.seamfit
    bpy.ops.wm.obj_import(filepath=str(BODY_BASE))
    s.target_body = bpy.context.selected_objects[0]
    before = object_fingerprint(s.target_body)
    with pytest.raises(RuntimeError, match=r"target body 'women_size06': .*wrong axes: the body is [+-]Y-up.*"
                                           r"rotate it [+-]90 degrees about X.*Up axis Z") as err:
        bpy.ops.seamfit.check_bodies()
    assert "\n" not in str(err.value).strip()
    assert not s.target_report.ok and "wrong axes" in s.target_report.message
    assert object_fingerprint(s.target_body) == before


def test_decimated_target_is_registered(scene):
    """A decimated copy of a sample body (another mesh) is accepted as the target and
    registered onto the base body's mesh, with its error shown."""
    s = scene.seamfit
    s.base_body = import_obj(BODY_BASE, "women_size06")
    target = import_obj(BODY_BASE, "scan")
    mod = target.modifiers.new("decimate", "DECIMATE")
    mod.ratio = 0.2
    before = object_fingerprint(target)
    s.target_body = target
    assert bpy.ops.seamfit.check_bodies() == {"FINISHED"}
    rep = s.target_report
    assert rep.ok and rep.registering and not rep.registered, rep.message
    assert not s.base_report.registering
    assert bpy.ops.seamfit.register_target() == {"FINISHED"}
    assert rep.registered
    assert 0.0 < rep.registration_mean_mm < 5.0 and rep.registration_max_mm >= rep.registration_mean_mm
    assert object_fingerprint(target) == before
    # Check Bodies again keeps showing it (the registration is kept for Adjust).
    assert bpy.ops.seamfit.check_bodies() == {"FINISHED"}
    assert rep.registered and rep.registration_mean_mm < 5.0
    from test_ui import Recorder
    log = []
    bpy.types.SEAMFIT_PT_bodies.draw(type("P", (), {"layout": Recorder(log)})(), bpy.context)
    assert ("operator", "seamfit.register_target") in log
    assert any(e[0] == "label" and e[1].startswith("Registered: ") and "mm mean" in e[1] for e in log)
    # Adjust grades to the registered mesh (reused, not made again).
    bpy.ops.seamfit.import_pattern(filepath=str(PENCIL))
    s.edge_length_cm, s.sdf_spacing_mm, s.iterations, s.exact_every = GRADE_EDGE_CM, 1000 * GRADE_SDF_M, 4, 4
    cache = addon().cache.CACHE
    made = cache.misses["register"]
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    assert cache.misses["register"] == made and cache.hits["register"] >= 1
    out = addon().solve.last_result("adjust")
    assert out.registration is not None and out.target_name == "scan"
    assert out.result.mesh.n_vertices == len(out.garment.x)
    assert bpy.data.collections.get("scan gc_pencil_skirt size06") is not None
    assert object_fingerprint(target) == before
