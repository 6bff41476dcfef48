# SPDX-License-Identifier: GPL-3.0-or-later
"""The grading methods of seamfit.opt.grade (``GradeSettings.method``) as the add-on names
them: Blender enum identifiers, labels and tooltips. No bpy here."""
from __future__ import annotations

DEFAULT = "ADJOINT"

# identifier: (seamfit's name, label, tooltip)
_METHODS = {
    "ADJOINT": ("adjoint", "Adjoint (Algorithm 1)",
                "Wang 2018, Algorithm 1: initialization, then adjoint gradient descent on the whole "
                "objective (default)"),
    "TWO_PHASE": ("two-phase", "Two-phase",
                  "Baseline, for comparison (Wang 2018, §3): transfer the garment to the target body, "
                  "then optimize the positional cost only (with the boundary regularizers)"),
    "FIXED_POINT": ("fixed-point", "Fixed-point",
                    "Baseline, for comparison (Bartle et al. 2016): drape, move each pattern triangle "
                    "towards the transferred garment's, repeat; no gradient"),
}


def items() -> list[tuple[str, str, str]]:
    """EnumProperty items."""
    return [(key, label, tip) for key, (_, label, tip) in _METHODS.items()]


def to_seamfit(identifier: str) -> str:
    """seamfit's name of the method (what `seamfit grade --method` takes)."""
    return _METHODS[identifier][0]


def from_seamfit(name: str) -> str:
    """The enum identifier of seamfit's method name; KeyError for an unknown one."""
    for key, (seamfit_name, _, _) in _METHODS.items():
        if seamfit_name == name:
            return key
    raise KeyError(name)


def label(name: str) -> str:
    """Label of a seamfit method name, for reports (the name itself when unknown)."""
    for seamfit_name, text, _ in _METHODS.values():
        if seamfit_name == name:
            return text
    return name
