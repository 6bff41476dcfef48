# SPDX-License-Identifier: GPL-3.0-or-later
"""Presets of the seven strengths (fix, cur, dis, smo, str, pos, seam).

seamfit's own presets (``seamfit.opt.PRESETS``) are used when the installed seamfit has
them; otherwise the same presets from Wang 2018, Table 1, under the same names, with
seamfit's seam-length strength (not in the paper; docs/optimizer.md).
"""
from __future__ import annotations

STRENGTH_KEYS = ("fix", "cur", "dis", "smo", "str", "pos", "seam")
DEFAULT = "dress"

_PAPER = {
    # name: (rule, (fix, cur, dis, smo, str, pos, seam))
    "fitted": ("Stretch garments worn under tension (bodysuit)", (100.0, 1e6, 0.01, 5e-5, 5.0, 100.0, 1e6)),
    "dress": ("Woven garments with ease (secretary dress)", (100.0, 1e6, 1.0, 0.05, 1.0, 100.0, 1e6)),
    "skirt_shirring": ("Gathered or shirred garments with designed folds (Carmen skirt)",
                       (100.0, 1e6, 0.01, 0.01, 1.0, 100.0, 1e6)),
    "pants": ("Trousers and jumpsuits (pants)", (100.0, 1e6, 1.0, 0.05, 1.0, 100.0, 1e6)),
}


def _from_seamfit() -> dict | None:
    try:
        from seamfit.opt import PRESETS  # type: ignore
    except Exception:   # seamfit missing or without presets: fall back to the table
        return None
    out = {}
    for key, p in PRESETS.items():
        if getattr(p, "name", key) != key:      # an alias of another preset
            continue
        s = p.strengths
        out[key] = (str(getattr(p, "rule", "")), tuple(float(getattr(s, k, 0.0)) for k in STRENGTH_KEYS))
    return out or None


def presets() -> dict[str, tuple[str, tuple[float, ...]]]:
    """{name: (when to use it, strengths)}."""
    return _from_seamfit() or dict(_PAPER)


def for_garment(garment_type: str | None) -> str | None:
    """The preset seamfit's "auto" picks for a pattern's garment kind (None when the
    installed seamfit has no such rule), so Adjust grades as `seamfit grade` does."""
    try:
        from seamfit.opt.presets import preset_for_garment  # type: ignore
    except Exception:
        return None
    name = preset_for_garment(garment_type)
    return name if name in presets() else None


def label(name: str) -> str:
    return name.replace("_", " ").capitalize()


def preset_items():
    items = [(k, label(k), v[0][:1].upper() + v[0][1:]) for k, v in presets().items()]
    return items + [("CUSTOM", "Custom", "Strengths set by hand")]
