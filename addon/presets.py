# SPDX-License-Identifier: GPL-3.0-or-later
"""Presets of the seven strengths (fix, cur, dis, smo, str, pos, seam): seamfit's own
(``seamfit.opt.PRESETS``, from Wang 2018, Table 1, with seamfit's seam-length strength)."""
from __future__ import annotations

from seamfit.opt import STRENGTH_NAMES as STRENGTH_KEYS

DEFAULT = "dress"


def _from_seamfit() -> dict:
    from seamfit.opt import PRESETS
    out = {}
    for key, p in PRESETS.items():
        if getattr(p, "name", key) != key:      # an alias of another preset
            continue
        out[key] = (str(getattr(p, "rule", "")), tuple(float(getattr(p.strengths, k)) for k in STRENGTH_KEYS))
    return out


def presets() -> dict[str, tuple[str, tuple[float, ...]]]:
    """{name: (when to use it, strengths)}."""
    return _from_seamfit()


def for_garment(garment_type: str | None) -> str | None:
    """The preset seamfit's "auto" picks for a pattern's garment kind (None when the
    rule picks none of these), so Adjust grades as `seamfit grade` does."""
    from seamfit.opt import preset_for_garment
    name = preset_for_garment(garment_type)
    return name if name in presets() else None


def label(name: str) -> str:
    return name.replace("_", " ").capitalize()


def preset_items():
    items = [(k, label(k), v[0][:1].upper() + v[0][1:]) for k, v in presets().items()]
    return items + [("CUSTOM", "Custom", "Strengths set by hand")]
