"""Strength presets: "auto" picks one by the pattern's garment kind; the skirt preset is the
dress's without the positional and smoothness costs."""
from dataclasses import replace

import pytest

from seamfit.opt.presets import PRESETS, preset, preset_for_garment


@pytest.mark.parametrize("kind, name", [
    ("pencil_skirt", "skirt"), ("circle_skirt", "skirt"), ("shirring_skirt", "skirt_shirring"),
    ("pants", "pants"), ("trousers", "pants"), ("jumpsuit", "pants"), ("leggings", "fitted"),
    ("bodice", "dress"), ("tshirt", "dress"), ("", "dress"), (None, "dress")])
def test_auto_picks_by_garment_kind(kind, name):
    assert preset_for_garment(kind) == name
    assert preset("auto", kind) is PRESETS[name]


def test_skirt_and_pants_are_the_dress_without_the_costs_that_hold_hanging_cloth():
    assert PRESETS["skirt"].strengths == replace(PRESETS["dress"].strengths, pos=0, smo=0)
    assert PRESETS["pants"].strengths == replace(PRESETS["dress"].strengths, pos=0, dis=0, smo=0)


def test_unknown_preset_names_the_choices():
    with pytest.raises(KeyError, match="auto or one of"):
        preset("jacket")
