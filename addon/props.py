# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings stored in the .blend: the scene's seamfit settings and, on collections made by
seamfit, a summary of the pattern they hold."""
from __future__ import annotations

import sys

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from seamfit import settings as seamfit_settings

from . import compute, methods, presets, scene_io

# Blender 4.2 keeps a reference to every PropertyGroup class after unregistering it (4.5 to
# those used as pointer or collection types), and through their methods and callbacks to
# these globals, bpy among them. Held by its own globals, this module lives as long as they
# do, so Python clears them at exit as it clears every live module's, and frees bpy: bpy 4.2
# and 4.5 run Blender's exit only then. Without it, whether bpy was freed depended on the
# order the add-on's modules happened to go in; when it was not, Blender freed its Python
# panels after Python had ended, and the process crashed (SIGSEGV) at exit.
_THIS_MODULE = sys.modules[__name__]


class SEAMFIT_PG_panel_info(bpy.types.PropertyGroup):
    n_vertices: IntProperty(name="Outline points")
    n_corners: IntProperty(name="Corners")
    area_cm2: FloatProperty(name="Area (cm²)")


class _StitchSides:
    """The two sides of a stitch, sewn or proposed: their panels and lengths."""
    panel_a: StringProperty(name="Side A")
    panel_b: StringProperty(name="Side B")
    length_a_cm: FloatProperty(name="Length A (cm)")
    length_b_cm: FloatProperty(name="Length B (cm)")


class SEAMFIT_PG_stitch_info(_StitchSides, bpy.types.PropertyGroup):
    gathered: BoolProperty(name="Gathered")


class SEAMFIT_PG_proposed_stitch(_StitchSides, bpy.types.PropertyGroup):
    """A stitch seamfit proposes for a pattern read from a DXF (which has none): the user
    accepts it, then Confirm Stitches puts the accepted ones into the pattern."""
    entry: StringProperty(description="The proposal as seamfit's seams sidecar entry (JSON)")
    accept: BoolProperty(name="Accept", default=False, description="Sew these two runs together")
    why: StringProperty(name="Why", description="Why seamfit proposes it")


class SEAMFIT_PG_fit(bpy.types.PropertyGroup):
    """Ease (garment girth minus body girth) of a garment on a body, in cm."""
    valid: BoolProperty(default=False)
    bust: FloatProperty(name="Bust ease (cm)")
    waist: FloatProperty(name="Waist ease (cm)")
    hip: FloatProperty(name="Hip ease (cm)")
    has_bust: BoolProperty(description="The garment goes round the body at bust level")
    has_waist: BoolProperty(description="The garment goes round the body at waist level")
    has_hip: BoolProperty(description="The garment goes round the body at hip level")


class SEAMFIT_PG_message(bpy.types.PropertyGroup):
    """A line for the user (its text is the name)."""


class SEAMFIT_PG_pattern_info(bpy.types.PropertyGroup):
    role: StringProperty(name="Role")
    source: StringProperty(name="Source file")
    body: StringProperty(name="Body", description="The body this pattern was graded or draped for")
    panels: CollectionProperty(type=SEAMFIT_PG_panel_info)
    stitches: CollectionProperty(type=SEAMFIT_PG_stitch_info)
    active_panel: IntProperty()
    active_stitch: IntProperty()
    fit: PointerProperty(type=SEAMFIT_PG_fit)
    objective: FloatProperty(name="Final objective")
    iterations: IntProperty(name="Iterations")
    method: StringProperty(name="Method", description="The grading method that made this pattern")
    warnings: CollectionProperty(type=SEAMFIT_PG_message)
    size: StringProperty(name="Size", description="The size read from a multi-size DXF")
    proposals: CollectionProperty(type=SEAMFIT_PG_proposed_stitch)
    active_proposal: IntProperty()


class SEAMFIT_PG_body_report(bpy.types.PropertyGroup):
    checked: BoolProperty(default=False)
    key: StringProperty(description="Content hash of the mesh that was checked")
    ok: BoolProperty(default=False)
    message: StringProperty()
    height: FloatProperty(name="Height (cm)")
    bust: FloatProperty(name="Bust (cm)")
    waist: FloatProperty(name="Waist (cm)")
    hip: FloatProperty(name="Hip (cm)")
    registering: BoolProperty(default=False, description="The body has another mesh than the base body: grading "
                              "registers the base body's mesh onto it")
    registered: BoolProperty(default=False)
    registration_mean_mm: FloatProperty(name="Registration error, mean (mm)")
    registration_max_mm: FloatProperty(name="Registration error, max (mm)")


# ---------------------------------------------------------------------------
# Body from measurements: one field per measurement seamfit knows (seamfit.body.MEASUREMENTS)

UNITS = {"CM": "cm", "IN": "in"}
MEASUREMENTS = compute.measurement_names()


def field_name(key: str) -> str:
    return f"m_{key}"


def cm_per_unit(units: str) -> float:
    return compute.unit_factor_cm(UNITS[units])


def _units_changed(self, context):
    """Convert the fields to the new unit: the body they describe stays the same."""
    old = self.units_shown if self.units_shown in UNITS else "CM"
    f = cm_per_unit(old) / cm_per_unit(self.units)
    for key in MEASUREMENTS:
        setattr(self, field_name(key), getattr(self, field_name(key)) * f)
    self.units_shown = self.units


_size_items: list = []      # Blender needs the enum's strings kept alive


def _sizes(self, context):
    _size_items[:] = [(str(i), s.name, f"{s.name} ({s.gender})") for i, s in enumerate(self.chart_sizes)] or \
        [("NONE", "No size chart", "Load a size chart first")]
    return _size_items


def _size_picked(self, context):
    if self.size != "NONE":
        self.apply_size(self.chart_sizes[int(self.size)])


class SEAMFIT_PG_chart_size(bpy.types.PropertyGroup):
    """One size of a loaded size chart (its name is the size's)."""
    gender: StringProperty()
    values_cm: StringProperty(description="The size's measurements (cm) as JSON")


def _measure_annotations() -> dict:
    fields = {field_name(k): FloatProperty(
        name=k.replace("_", " ").capitalize(), default=0.0, min=0.0, soft_max=250.0, precision=1,
        description=f"{k.replace('_', ' ').capitalize()} in the chosen unit; 0: not measured, the body model "
                    "infers it") for k in MEASUREMENTS}
    return {
        "units": EnumProperty(name="Units", default="CM", update=_units_changed, items=[
            ("CM", "cm", "Measurements in centimetres"), ("IN", "in", "Measurements in inches")]),
        "units_shown": StringProperty(default="CM", options={"HIDDEN"}),
        "gender": EnumProperty(name="Gender", default="female", items=[
            ("female", "Female", "The female body model (prior: the size 6 sample body)"),
            ("male", "Male", "The male body model (prior: the men's medium sample body)")]),
        "body_name": StringProperty(name="Name", default="body", description="Name of the body object to add"),
        "chart": StringProperty(name="Size chart", description="The size chart the sizes come from"),
        "chart_sizes": CollectionProperty(type=SEAMFIT_PG_chart_size),
        "size": EnumProperty(name="Size", items=_sizes, update=_size_picked,
                             description="Fill the fields with a size of the chart"),
        **fields,
    }


def _apply_size(self, size) -> None:
    """Fill the fields with a size of the chart (in the chosen unit); measurements the size
    does not give are cleared (the model infers them)."""
    import json
    cm = json.loads(size.values_cm)
    f = cm_per_unit(self.units)
    for key in MEASUREMENTS:
        setattr(self, field_name(key), cm.get(key, 0.0) / f)
    self.gender = size.gender if size.gender in ("female", "male") else "female"
    self.body_name = size.name


def _requested_cm(self) -> dict:
    """The measurements given (cm): every field above 0."""
    f = cm_per_unit(self.units)
    return {k: _exact(getattr(self, field_name(k))) * f for k in MEASUREMENTS if getattr(self, field_name(k)) > 0}


SEAMFIT_PG_measure = type("SEAMFIT_PG_measure", (bpy.types.PropertyGroup,), {
    "__doc__": "The Body from measurements panel's fields",
    "__annotations__": _measure_annotations(),
    "apply_size": _apply_size,
    "requested_cm": _requested_cm,
})


def _is_pattern(self, coll):
    return scene_io.is_pattern_collection(coll) and coll.get(scene_io.ROLE_KEY) not in ("drape", "compare")


def _recolor(self, context):
    scene_io.recolor_all(context.scene)


def _is_mesh(self, obj):
    return obj.type == "MESH"


_PRESETS = presets.presets()
_applying_preset = False


def _apply_preset(self, context):
    global _applying_preset
    if self.strength_preset == "CUSTOM":
        return
    values = _PRESETS.get(self.strength_preset)
    if values is None:
        return
    _applying_preset = True
    try:
        for key, val in zip(presets.STRENGTH_KEYS, values[1]):
            setattr(self, f"strength_{key}", val)
    finally:
        _applying_preset = False


def _strength_edited(self, context):
    if not _applying_preset and self.strength_preset != "CUSTOM":
        preset = _PRESETS.get(self.strength_preset)
        if preset is not None and any(
                abs(getattr(self, f"strength_{k}") - v) > 1e-6 * max(1e-6, abs(v))
                for k, v in zip(presets.STRENGTH_KEYS, preset[1])):
            self.strength_preset = "CUSTOM"


def _strength(key: str, default: float):
    """The scene property of one term's strength (its label and help from seamfit.opt.STRENGTH_HELP)."""
    from seamfit.opt import STRENGTH_HELP
    name, desc = STRENGTH_HELP[key]
    return FloatProperty(name=name, description=desc + " (1/m²)", default=default, min=0.0,
                         soft_max=1e7, precision=4, update=_strength_edited)


_DEFAULT_PRESET = presets.DEFAULT if presets.DEFAULT in _PRESETS else next(iter(_PRESETS))
_default = _PRESETS[_DEFAULT_PRESET][1]



def _setting(key: str):
    """The scene property of seamfit's setting ``key`` (its label, default, unit and range
    from the setting's one declaration, seamfit.settings)."""
    kind = getattr(bpy.props, seamfit_settings.blender_kind(key))
    return kind(**seamfit_settings.blender_property(key))


# scene property -> seamfit setting (the property names are the ones saved in .blend files)
SETTING_PROPS = {s.addon.prop: key for key, s in seamfit_settings.table().items() if s.addon is not None}


class SEAMFIT_PG_run_target(bpy.types.PropertyGroup):
    """A target body of Grade Size Run: a mesh object of the scene or a body file."""
    obj: PointerProperty(type=bpy.types.Object, poll=_is_mesh, name="Body",
                         description="A mesh object of the scene as the target body")
    filepath: StringProperty(name="Body file", subtype="FILE_PATH",
                             description="A body file (.obj/.ply, metres, Z up, facing -Y) as the target body")


class SEAMFIT_PG_settings(bpy.types.PropertyGroup):
    pattern: PointerProperty(type=bpy.types.Collection, poll=_is_pattern, name="Pattern",
                             description="The base pattern that drape and adjust use")
    edge_length_cm: _setting("grade.edge_length_cm")
    base_body: PointerProperty(type=bpy.types.Object, poll=_is_mesh, name="Base body",
                               description="The body the base pattern was made for")
    target_body: PointerProperty(type=bpy.types.Object, poll=_is_mesh, name="Target body",
                                 description="The body to grade the pattern to: any mesh object (one of another mesh "
                                             "than the base body, a scan or a character, is registered first)")
    run_targets: CollectionProperty(type=SEAMFIT_PG_run_target, name="Size run targets",
                                    description="The bodies Grade Size Run grades to, smallest to largest")
    active_run_target: IntProperty()
    base_report: PointerProperty(type=SEAMFIT_PG_body_report)
    target_report: PointerProperty(type=SEAMFIT_PG_body_report)
    measure: PointerProperty(type=SEAMFIT_PG_measure)

    strength_preset: EnumProperty(name="Preset", items=presets.preset_items(), default=_DEFAULT_PRESET,
                                  update=_apply_preset,
                                  description="Strengths suited to a kind of garment (Wang 2018, Table 1)")
    method: EnumProperty(
        name="Method", items=methods.items(), default=methods.DEFAULT,
        description="How the adjusted pattern is searched for (seamfit grade --method). The "
                    "baselines are there for comparison; every result is scored with the same objective")

    fabric_stretch: _setting("fabric.stretch_stiffness")
    fabric_sewing: _setting("fabric.sewing_stiffness")
    fabric_bending: _setting("fabric.bending_stiffness")
    fabric_density: _setting("fabric.density")
    mu: _setting("sim.mu")
    sim_iterations: _setting("sim.max_iterations")
    sdf_spacing_mm: _setting("grade.sdf_spacing")
    steps_per_iteration: _setting("grade.inner_iterations")
    exact_every: _setting("grade.checkpoint_every")
    iterations: _setting("grade.max_outer_iterations")
    device: _setting("grade.device")
    grade_options: StringProperty(
        name="More grading settings", default="",
        description="Further settings of seamfit's grading (seamfit.opt.GradeSettings) as JSON, e.g. "
                    "{\"start\": \"base\", \"time_budget_s\": 600}; scripts/batch_grade.py sets them from "
                    "seamfit grade's options")
    show_overlay: BoolProperty(name="Pattern overlay", default=True,
                               description="Draw corners and stitch lengths in the viewport")
    keep_results: BoolProperty(
        name="Keep previous results", default=False,
        description="Drape and Adjust add a new result next to the previous one instead of replacing it")
    stretch_measure: EnumProperty(
        name="Stretch map", default="EDGE", update=_recolor,
        items=[(k, v[1], v[2]) for k, v in scene_io.STRETCH_MEASURES.items()],
        description="What the garments' colours show")
    stretch_range: EnumProperty(name="Colour range", default="AUTO", update=_recolor, items=[
        ("AUTO", "From the data", "The smallest round range that holds 99 % of the garment's vertices"),
        ("FIXED", "Fixed", "The range set below, the same for every garment"),
    ], description="Which strain is shown fully red (stretched) or blue (compressed)")
    stretch_span_pct: FloatProperty(name="Range (±%)", default=10.0, min=0.1, soft_max=100.0, precision=1,
                                    update=_recolor, description="Strain shown fully red or blue, in %")
    show_legend: BoolProperty(name="Legend", default=True,
                              description="Draw the stretch map's colour legend in the viewport")
    compare_layout: EnumProperty(name="Layout", default="SIDE_BY_SIDE",
                                 items=[(k, *v) for k, v in scene_io.COMPARE_LAYOUTS.items()],
                                 description="How Compare lays the base and graded panels out")


# One strength property per term of f, in seamfit's order: a new term needs no line here.
SEAMFIT_PG_settings.__annotations__.update(
    {f"strength_{k}": _strength(k, v) for k, v in zip(presets.STRENGTH_KEYS, _default)})

CLASSES = (SEAMFIT_PG_panel_info, SEAMFIT_PG_stitch_info, SEAMFIT_PG_proposed_stitch, SEAMFIT_PG_fit,
           SEAMFIT_PG_message, SEAMFIT_PG_pattern_info, SEAMFIT_PG_body_report, SEAMFIT_PG_chart_size,
           SEAMFIT_PG_measure, SEAMFIT_PG_run_target, SEAMFIT_PG_settings)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    bpy.types.Scene.seamfit = PointerProperty(type=SEAMFIT_PG_settings)
    bpy.types.Collection.seamfit = PointerProperty(type=SEAMFIT_PG_pattern_info)


def unregister():
    del bpy.types.Collection.seamfit
    del bpy.types.Scene.seamfit
    _unregister_classes()


_exact = seamfit_settings.typed_decimal


def settings_dict(s: SEAMFIT_PG_settings) -> dict:
    """The scene settings as plain data for a worker thread: each of seamfit's settings
    under its owner (grade, sim, fabric) by its field name, in seamfit's units."""
    out: dict = {"grade": {}, "sim": {}, "fabric": {}}
    for prop, key in SETTING_PROPS.items():
        owner, name = key.split(".")
        out[owner][name] = seamfit_settings.from_blender(key, getattr(s, prop))
    out.update({
        "strengths": {k: _exact(getattr(s, f"strength_{k}")) for k in presets.STRENGTH_KEYS},
        "method": methods.to_seamfit(s.method),
        "grade_options": _grade_options(s.grade_options),
    })
    return out


def _grade_options(text: str) -> dict:
    import json
    if not text.strip():
        return {}
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise compute.AddonError(f"More grading settings: not JSON ({exc})") from None
    if not isinstance(value, dict):
        raise compute.AddonError("More grading settings: must be a JSON object of setting: value")
    return value
