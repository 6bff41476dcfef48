# SPDX-License-Identifier: GPL-3.0-or-later
"""Adjust warns when the base pattern does not look made for the base body (its base drape's
girth nearer the target body's than the base body's), with the numbers."""
import bpy
import pytest

from helpers import PENCIL, addon, grading_scene_for

PENCIL_10 = PENCIL.parents[1] / "size10" / "pattern.json"


def test_the_rule_on_measured_numbers(installed):
    warn = addon().compute.fit_warnings
    girths6 = {"bust": 89.7, "waist": 64.0, "hip": 96.5}
    girths10 = {"bust": 94.7, "waist": 69.1, "hip": 101.6}
    # The size-6 pencil skirt on the size-6 body: 0.4 cm of hip ease, as made.
    assert warn({"bust": None, "waist": None, "hip": 0.35}, girths6, girths10, "women_size06", "women_size10") == []
    # The size-10 skirt on the size-6 body: 3.7 cm, its hip girth nearer the size-10 body's.
    (line,) = warn({"hip": 3.66}, girths6, girths10, "women_size06", "women_size10")
    assert "larger body than women_size06" in line
    assert "100.2 cm" in line and "96.5 cm" in line and "+3.7 cm" in line and "101.6 cm" in line
    # Grading down from a pattern too small for its base body.
    (line,) = warn({"hip": -3.0}, girths10, girths6, "women_size10", "women_size06")
    assert "smaller body than women_size10" in line
    # The pattern's own body name, when it names the target.
    lines = warn({"hip": 0.3}, girths6, girths10, "women_size06", "women_size10", pattern_body="size10")
    assert lines == ["the base pattern says it was made for 'size10', which names the target women_size10, "
                     "not the base body women_size06"]


def test_adjust_warns_for_a_pattern_of_another_body(scene):
    grading_scene_for(scene, PENCIL_10)
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}      # a warning, not a refusal
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "graded"]
    lines = [w.name for w in coll.seamfit.warnings]
    assert any("looks made for a larger body than women_size06" in w for w in lines), lines
    assert any("'size10'" in w for w in lines)
    out = addon().solve.last_result()
    ease = out.report["ease_cm"]["base"]["hip"]
    assert f"(ease {ease:+.1f} cm)" in lines[0]
    assert out.warnings == lines


def test_no_warning_for_the_pattern_of_the_base_body(grading_scene):
    assert bpy.ops.seamfit.adjust() == {"FINISHED"}
    (coll,) = [c for c in bpy.data.collections if c.seamfit.role == "graded"]
    assert len(coll.seamfit.warnings) == 0
