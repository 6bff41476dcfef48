"""Measurement sets: what a body is made from. Reading (seamfit JSON, Seamly2D / Valentina
individual ``.vit`` and multi-size ``.vst``) and checking them.

A :class:`MeasurementSet` holds one body's measurements in cm, by seamfit's names
(``MEASUREMENTS``: height, bust, underbust, waist, hip, shoulder, nape_to_waist,
waist_to_hip, upper_arm, thigh, neck, inseam); any subset may be given. Every value is
checked before any fitting: a number, positive, within a plausible range for that
measurement (which catches wrong units), and consistent with the others. Each failure is
a :class:`MeasurementError` naming the file, the body and the measurement.
"""
from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import SeamfitError
from .measure import MEASUREMENTS

__all__ = ["MeasurementError", "MeasurementSet", "check_measurements", "load_measurement_sets"]


class MeasurementError(SeamfitError):
    """A measurement file or value that cannot make a body."""


MEASUREMENT_UNITS = {"cm": 1.0, "mm": 0.1, "m": 100.0, "in": 2.54, "inch": 2.54, "inches": 2.54}

# Plausible adult values (cm), wide: outside them the units are the likely mistake.
RANGES_CM = {
    "height": (120, 220), "bust": (60, 170), "underbust": (55, 160), "waist": (45, 170),
    "hip": (60, 180), "shoulder": (25, 55), "nape_to_waist": (28, 60), "waist_to_hip": (8, 40),
    "upper_arm": (15, 60), "thigh": (30, 95), "neck": (24, 60), "inseam": (55, 100),
}

# Seamly2D / Valentina measurement names (their known-measurements database) -> seamfit's.
SEAMLY_NAMES = {
    "height": "height", "bust_circ": "bust", "lowbust_circ": "underbust", "waist_circ": "waist",
    "hip_circ": "hip", "width_shoulder": "shoulder", "neck_back_to_waist_b": "nape_to_waist",
    "height_waist_side_to_hip": "waist_to_hip", "arm_upper_circ": "upper_arm",
    "leg_thigh_upper_circ": "thigh", "neck_mid_circ": "neck", "leg_crotch_to_floor": "inseam",
}


@dataclass
class MeasurementSet:
    """One body's measurements (cm, seamfit's names), its name and gender."""

    cm: dict
    name: str = "body"
    gender: str = "female"
    source: str | None = None
    ignored: list = field(default_factory=list)      # names in the file seamfit does not use

    @property
    def where(self) -> str:
        return f"{self.source}: {self.name}" if self.source else self.name


def check_measurements(cm: dict, where: str = "measurements") -> dict:
    """Values (cm) checked one by one and against each other; returns them as floats."""
    out = {}
    for key, value in cm.items():
        if value is None:                        # null: not measured, left to the model
            continue
        if key not in MEASUREMENTS:
            raise MeasurementError(f"{where}: {key!r} is not a measurement seamfit knows; "
                                   f"known: {', '.join(MEASUREMENTS)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise MeasurementError(f"{where}: {key} = {value!r} is not a number")
        v = float(value)
        if not math.isfinite(v):
            raise MeasurementError(f"{where}: {key} = {value!r} is not a finite number")
        if v <= 0:
            raise MeasurementError(f"{where}: {key} = {v:g} cm is not a length (it must be positive)")
        lo, hi = RANGES_CM[key]
        if not lo <= v <= hi:
            raise MeasurementError(f"{where}: {key} = {v:g} cm is outside {lo}-{hi} cm, the range of "
                                   "adult bodies; are the units right?")
        out[key] = v
    _check_consistent(out, where)
    return out


def _check_consistent(cm: dict, where: str) -> None:
    def rule(a, b, ok, why):
        if a in cm and b in cm and not ok(cm[a], cm[b]):
            raise MeasurementError(f"{where}: inconsistent: {a} {cm[a]:g} cm and {b} {cm[b]:g} cm ({why})")

    rule("underbust", "bust", lambda u, b: u <= b, "the underbust cannot exceed the bust")
    rule("waist", "hip", lambda w, h: w <= h + 25, "a waist more than 25 cm over the hip")
    rule("waist", "bust", lambda w, b: w <= b + 30, "a waist more than 30 cm over the bust")
    rule("thigh", "hip", lambda t, h: t < 0.75 * h, "a thigh girth of 3/4 of the hip or more")
    rule("neck", "bust", lambda n, b: n < 0.6 * b, "a neck girth of 0.6 of the bust or more")
    rule("inseam", "height", lambda i, h: 0.35 * h <= i <= 0.56 * h, "an inseam outside 0.35-0.56 of the height")
    rule("nape_to_waist", "height", lambda n, h: 0.18 * h <= n <= 0.32 * h,
         "a nape to waist length outside 0.18-0.32 of the height")


# ----------------------------------------------------------------------------- reading

def load_measurement_sets(path) -> list[MeasurementSet]:
    """The measurement sets in a file: seamfit JSON (one body or several), a Seamly2D /
    Valentina individual file (.vit, .smis: one body) or multi-size table (.vst, .smms:
    one body per size), detected from the content."""
    from ..limits import check_input_file, read_text_file
    path = Path(path)
    check_input_file(path, "measurements", MeasurementError)   # a FIFO would block, a device never end
    text = read_text_file(path, "measurement file", MeasurementError)
    head = text.lstrip()[:1]
    if head in ("{", "["):
        sets = _from_json(text, path)
    elif head == "<":
        sets = _from_xml(text, path)
    else:
        raise MeasurementError(f"{path}: not a measurement file (expected seamfit JSON or a Seamly2D / "
                               "Valentina .vit or .vst file)")
    if not sets:
        raise MeasurementError(f"{path}: holds no measurement set")
    for s in sets:
        s.cm = check_measurements(s.cm, s.where)
    return sets


def _unit_factor(unit, where: str) -> float:
    if unit is None:
        raise MeasurementError(f"{where}: missing units; add \"units\": \"cm\" (or mm, m, in)")
    factor = MEASUREMENT_UNITS.get(str(unit).strip().lower())
    if factor is None:
        raise MeasurementError(f"{where}: unknown units {unit!r}; use one of {', '.join(MEASUREMENT_UNITS)}")
    return factor


def _gender(value, where: str) -> str:
    g = "female" if value in (None, "", "unknown") else str(value).strip().lower()
    if g not in ("female", "male"):
        raise MeasurementError(f"{where}: gender {value!r} is not 'female' or 'male'")
    return g


def _from_json(text: str, path: Path) -> list[MeasurementSet]:
    """{"units": "cm", "gender": ..., "name": ..., "measurements": {...}}, or
    {"units": "cm", "bodies": {name: {"gender": ..., "measurements": {...}}}}. A body's
    values may instead be given in cm under "measurements_cm" (or "requested_cm", as in
    the sample bodies' measurements.json), which needs no "units"."""
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise MeasurementError(f"{path}: not valid JSON: {exc}") from None
    except RecursionError:
        raise MeasurementError(f"{path}: JSON nested too deeply to be a measurement file") from None
    if not isinstance(doc, dict):
        raise MeasurementError(f"{path}: expected a JSON object with \"measurements\" or \"bodies\"")
    if "bodies" in doc:
        bodies = doc["bodies"]
        if not isinstance(bodies, dict):
            raise MeasurementError(f"{path}: \"bodies\" must map body names to their measurements")
        entries = list(bodies.items())
    else:
        entries = [(doc.get("name") or path.stem, doc)]
    sets = []
    for name, entry in entries:
        where = f"{path}: {name}" if "bodies" in doc else str(path)
        if not isinstance(entry, dict):
            raise MeasurementError(f"{where}: expected an object with \"measurements\"")
        for key in ("measurements_cm", "requested_cm"):
            if key in entry:
                values, factor = entry[key], 1.0
                break
        else:
            if "measurements" not in entry:
                raise MeasurementError(f"{where}: no \"measurements\"")
            values = entry["measurements"]
            factor = _unit_factor(entry.get("units", doc.get("units")), where)
        if not isinstance(values, dict):
            raise MeasurementError(f"{where}: the measurements must be an object of name: value")
        cm = {k: (v * factor if isinstance(v, (int, float)) and not isinstance(v, bool) else v)
              for k, v in values.items()}
        sets.append(MeasurementSet(cm, name=str(name), source=str(path),
                                   gender=_gender(entry.get("gender", doc.get("gender")), where)))
    return sets


def _from_xml(text: str, path: Path) -> list[MeasurementSet]:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise MeasurementError(f"{path}: not valid XML: {exc}") from None
    if root.tag in ("vit", "smis"):
        return [_individual(root, path)]
    if root.tag in ("vst", "smms"):
        return _multisize(root, path)
    raise MeasurementError(f"{path}: <{root.tag}> is not a Seamly2D / Valentina measurement file "
                           "(<vit> or <vst>)")


def _xml_unit(root, path: Path) -> float:
    unit = root.findtext("unit")
    return _unit_factor(None if unit is None else unit.strip(), str(path))


def _number(text, what: str, where: str) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        raise MeasurementError(f"{where}: {what} = {text!r} is not a number (seamfit reads values, "
                               "not formulas)") from None


def _individual(root, path: Path) -> MeasurementSet:
    factor = _xml_unit(root, path)
    cm, ignored = {}, []
    for m in root.iter("m"):
        name = m.get("name", "")
        if name not in SEAMLY_NAMES:
            ignored.append(name)
            continue
        cm[SEAMLY_NAMES[name]] = _number(m.get("value"), name, str(path)) * factor
    personal = root.find("personal")
    given = "" if personal is None else " ".join(
        t for t in ((personal.findtext("given-name") or "").strip(),
                    (personal.findtext("family-name") or "").strip()) if t)
    gender = None if personal is None else personal.findtext("gender")
    return MeasurementSet(cm, name=given.replace(" ", "_") or path.stem, source=str(path),
                          gender=_gender(gender, str(path)), ignored=ignored)


def _multisize(root, path: Path) -> list[MeasurementSet]:
    """One set per size of the table, at its base height. A measurement's value at size s
    and height h is base + (s - base size) / size step * size_increase + (h - base height)
    / height step * height_increase; steps are 2 and 6 (sizes and heights in cm), x10 in mm."""
    factor = _xml_unit(root, path)
    size_el, height_el = root.find("size"), root.find("height")
    if size_el is None or height_el is None:
        raise MeasurementError(f"{path}: a multi-size table needs <size base=...> and <height base=...>")
    mm = (root.findtext("unit") or "").strip() == "mm"
    base_size = _number(size_el.get("base"), "size base", str(path))
    size_step = _number(size_el.get("step", 20 if mm else 2), "size step", str(path))
    listed = [_number(s.get("value"), "size", str(path)) for s in root.findall("sizes/size")]
    if listed:
        sizes = listed
    elif size_el.get("min") is not None and size_el.get("max") is not None:
        lo = _number(size_el.get("min"), "size min", str(path))
        hi = _number(size_el.get("max"), "size max", str(path))
        sizes = [lo + k * size_step for k in range(int(round((hi - lo) / size_step)) + 1)]
    else:
        sizes = [base_size]
    rows, ignored = [], []
    for m in root.iter("m"):
        name = m.get("name", "")
        if name not in SEAMLY_NAMES:
            ignored.append(name)
            continue
        rows.append((SEAMLY_NAMES[name], _number(m.get("base"), f"{name} base", str(path)),
                     _number(m.get("size_increase", 0), f"{name} size_increase", str(path))))
    sets = []
    for s in sizes:
        k = (s - base_size) / size_step
        cm = {key: (base + k * inc) * factor for key, base, inc in rows}
        label = f"size{s:g}"
        sets.append(MeasurementSet(cm, name=label, source=str(path), ignored=list(ignored)))
    return sets
