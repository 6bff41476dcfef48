# SPDX-License-Identifier: GPL-3.0-or-later
"""Presets of the six strengths (fix, cur, dis, smo, str, pos), in 1/m^2.

seamfit's own presets are used when the installed seamfit provides them; these are the
coefficients of Wang 2018, Table 1, for the same kinds of garment.
"""
from __future__ import annotations

STRENGTH_KEYS = ("fix", "cur", "dis", "smo", "str", "pos")

_PAPER = {
    # id: (label, description, (fix, cur, dis, smo, str, pos))
    "woven": ("Woven, regular fit", "Dresses, jumpsuits, trousers (Wang 2018: secretary dress, pants)",
              (100.0, 1e6, 1.0, 0.05, 1.0, 100.0)),
    "stretch": ("Stretch, tight fit", "Bodysuits and other garments under constant stretch",
                (100.0, 1e6, 0.01, 5e-5, 5.0, 100.0)),
    "drapey": ("Loose, designed folds", "Skirts with shirring or designed wrinkles (Carmen skirt)",
               (100.0, 1e6, 0.01, 0.01, 1.0, 100.0)),
    "positional": ("Positional only", "Keep every garment point where it sits on the body",
                   (100.0, 1e6, 0.0, 0.0, 0.0, 100.0)),
}


def presets() -> dict[str, tuple[str, str, tuple[float, ...]]]:
    try:
        from seamfit import opt  # type: ignore
        given = getattr(opt, "PRESETS", None)
    except ImportError:
        given = None
    if isinstance(given, dict) and given:
        out = {}
        for key, val in given.items():
            strengths = val.get("strengths", val) if isinstance(val, dict) else val
            if isinstance(strengths, dict):
                strengths = tuple(float(strengths[k]) for k in STRENGTH_KEYS)
            label = val.get("label", key) if isinstance(val, dict) else key
            desc = val.get("description", "") if isinstance(val, dict) else ""
            out[str(key)] = (str(label), str(desc), tuple(strengths))
        return out
    return dict(_PAPER)


def preset_items():
    return [(k, v[0], v[1]) for k, v in presets().items()] + [("CUSTOM", "Custom", "Strengths set by hand")]
