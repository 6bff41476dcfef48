"""A graded size run in DXF-ASTM: every size in one file, and the base with grade rules.

Two forms are written (docs/formats.md, "Size runs"):

* ``write_size_run_dxf``: the multi-size form. One block per piece and size, each with its
  ``Size:`` text, all sizes of a piece inserted on one spot, aligned at the piece's
  bounding-box top-centre (the nest pattern makers check): the base size black (colour 7),
  the others in colour. The header's ``Sample Size:`` names the base.
* ``write_graded_dxf``: the base size only, with a grade-rule number (``# n`` text, layer 1)
  at each grade point (every edge end, corner and landmark), and the RUL table beside it:
  per rule, each size's move (x, y) of that point from the base size, in the drawing's
  units, in the same top-centre frame. Points that move alike share a rule.

Reading (``read_dxf_sizes``): the pieces of any DXF grouped by their ``Size:`` text, one
pattern per size; ``one_size`` picks the one a command works on. The graded form is read
back by seamfit.pattern.dxf_graded (``parse_rul`` reads its table).
"""
from __future__ import annotations

import copy
import dataclasses
import io
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_bytes, atomic_write_text
from .dxf import UNITS_CM, build_dxf, read_dxf_pieces, unique_names
from .model import Pattern

BASE_COLOR = 7                       # AutoCAD colour index: black on a white sheet
SIZE_COLORS = (1, 5, 3, 6, 30, 4, 140, 200, 40, 90)   # red, blue, green, magenta, orange, cyan, ...
GAP_CM = 5.0
RULE_DIGITS = 3                      # moves rounded to 0.001 drawing units before rules are shared


def _anchor(o: np.ndarray) -> np.ndarray:
    return np.array([0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()])


def _check(patterns: Sequence[Pattern], labels: Sequence[str], base_index: int, where: str) -> None:
    if len(patterns) != len(labels) or not 0 <= base_index < len(patterns):
        raise PatternError(f"{where}: {len(patterns)} patterns, {len(labels)} size names, base at {base_index}")
    names = [p.name for p in patterns[base_index].panels]
    for lab, pat in zip(labels, patterns):
        if [p.name for p in pat.panels] != names:
            raise PatternError(f"{where}: size {lab} has other pieces than the base "
                               f"({', '.join(p.name for p in pat.panels)} against {', '.join(names)})")


def _write(doc, path: Path) -> Path:
    buf = io.StringIO()
    doc.write(buf)
    return atomic_write_bytes(Path(path), buf.getvalue().encode(doc.output_encoding, errors="dxfreplace"))


def write_size_run_dxf(path, patterns: Sequence[Pattern], labels: Sequence[str], base_index: int, *,
                       units: str = "mm") -> Path:
    """Every size of a graded run in one DXF-ASTM file (see the module's text)."""
    path = Path(path)
    _check(patterns, labels, base_index, str(path))
    base = patterns[base_index]
    # Each piece's place on the sheet: wide enough for its largest size, left to right.
    slots, x = {}, 0.0
    for k, panel in enumerate(base.panels):
        lo = np.full(2, np.inf)
        hi = -lo
        for pat in patterns:
            o = np.asarray(pat.panels[k].outline_cm, dtype=float)
            rel = o - _anchor(o)
            lo, hi = np.minimum(lo, rel.min(axis=0)), np.maximum(hi, rel.max(axis=0))
        slots[panel.name] = np.array([x - lo[0], 0.0])
        x += float(hi[0] - lo[0]) + GAP_CM
    merged = copy.deepcopy(base)
    merged.panels, merged.stitches = [], []
    header = dict((merged.extra.get("dxf") or {}).get("header") or {})
    header["sample_size"] = labels[base_index]
    merged.extra["dxf"] = {**(merged.extra.get("dxf") or {}), "header": header}
    colors = []
    others = [k for k in range(len(patterns)) if k != base_index]
    # sizes in the run's order, so that a reader lists them smallest to largest
    for k in range(len(patterns)):
        for panel in patterns[k].panels:
            p = copy.deepcopy(panel)
            o = np.asarray(p.outline_cm, dtype=float)
            dxf = dict(p.extra.get("dxf") or {}) if isinstance(p.extra.get("dxf"), dict) else {}
            dxf.pop("texts", None)
            dxf["block"] = f"{panel.name} {labels[k]}"
            dxf["insert_cm"] = (slots[panel.name] - _anchor(o)).tolist()
            p.extra["dxf"] = dxf
            p.extra["size"] = labels[k]
            merged.panels.append(p)
            colors.append(BASE_COLOR if k == base_index else SIZE_COLORS[others.index(k) % len(SIZE_COLORS)])
    doc = build_dxf(merged, flavor="astm", units=units, name=path.name)
    inserts = list(doc.modelspace().query("INSERT"))
    for ref, color in zip(inserts, colors):
        for e in doc.blocks.get(ref.dxf.name):
            e.dxf.color = color
    return _write(doc, path)


def grade_points(panel) -> list[int]:
    """Outline indices a grade rule is attached to: edge ends, corners and landmarks."""
    pts = set(int(i) for i in panel.nodes) | set(int(i) for i in panel.corners)
    for idx in panel.landmarks.values():
        for i in (idx if isinstance(idx, (list, tuple)) else [idx]):
            pts.add(int(i))
    n = len(panel.outline_cm)
    return sorted(i for i in pts if 0 <= i < n)


def grade_rules(patterns: Sequence[Pattern], labels: Sequence[str], base_index: int, *,
                units: str = "mm") -> tuple[list[np.ndarray], dict[str, dict[int, int]]]:
    """The rule table and which rule each grade point follows: (rules, {panel: {vertex: rule}}).
    rules[r] is (sizes, 2): each size's move of the point from the base size, in ``units``,
    with each panel's copies aligned at their top-centre. Equal moves share one rule
    (number r + 1 in the files)."""
    _check(patterns, labels, base_index, "grade rules")
    k_units = 1.0 / UNITS_CM[units]
    base = patterns[base_index]
    rules: list[np.ndarray] = []
    index: dict[tuple, int] = {}
    points: dict[str, dict[int, int]] = {}
    for j, panel in enumerate(base.panels):
        ob = np.asarray(panel.outline_cm, dtype=float)
        rel_b = ob - _anchor(ob)
        points[panel.name] = {}
        moves = []
        for pat in patterns:
            o = np.asarray(pat.panels[j].outline_cm, dtype=float)
            if len(o) != len(ob):
                raise PatternError(f"grade rules: piece {panel.name!r} has {len(o)} outline points in one size "
                                   f"and {len(ob)} in the base; grade rules need the same points")
            moves.append((o - _anchor(o)) - rel_b)
        moves = np.stack(moves, axis=1) * k_units          # (n, sizes, 2)
        for i in grade_points(panel):
            m = np.round(moves[i], RULE_DIGITS) + 0.0       # + 0.0: no negative zeros
            key = tuple(m.ravel().tolist())
            if key not in index:
                index[key] = len(rules)
                rules.append(m)
            points[panel.name][i] = index[key]
    return rules, points


def format_rul(rules: Sequence[np.ndarray], labels: Sequence[str], base_index: int, *, name: str,
               units: str = "mm") -> str:
    """The grade-rule table as ASTM D6673's RUL text: header, the size list and sample size,
    then each rule's (x, y) move per size from the sample size."""
    lines = ["ASTM/D13Proposal 1 VERSION: D 13.4",
             "PRODUCT: seamfit",
             f"GRADE RULE TABLE: {name}",
             f"NUMBER OF SIZES: {len(labels)}",
             "SIZE LIST: " + " ".join(str(lab).replace(" ", "_") for lab in labels),
             f"SAMPLE SIZE: {str(labels[base_index]).replace(' ', '_')}",
             f"UNITS: {'METRIC' if units == 'mm' else 'ENGLISH'}"]
    for r, m in enumerate(rules):
        lines.append(f"RULE: DELTA {r + 1}")
        lines.append(" ".join(f"{dx:.{RULE_DIGITS}f},{dy:.{RULE_DIGITS}f}" for dx, dy in m))
    lines.append("END")
    return "\r\n".join(lines) + "\r\n"


RUL_UNITS = {"METRIC": "mm", "ENGLISH": "in"}


def parse_rul(text: str, where: str = "RUL table") -> dict:
    """A RUL grade-rule table (ASTM D6673, as :func:`format_rul` writes it): ``sizes``,
    ``sample_size``, ``units`` ('mm' for METRIC, 'in' for ENGLISH) and ``rules`` (number ->
    (sizes, 2) array of DELTA moves from the sample size; a rule's moves may run over several
    lines). Anything else is a PatternError naming ``where``, the line and the rule."""
    out: dict = {"rules": {}}
    current: int | None = None
    moves: list[list[float]] = []

    def close(lineno: int) -> None:
        if current is not None and len(moves) != len(out["sizes"]):
            raise PatternError(f"{where}: rule {current} has {len(moves)} moves, the SIZE LIST "
                               f"{len(out['sizes'])} sizes (line {lineno})")
        if current is not None:
            out["rules"][current] = np.array(moves, dtype=float).reshape(-1, 2)

    lineno = 0
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        key = key.strip().upper()
        if line.upper() == "END":
            break
        if sep and key == "SIZE LIST":
            out["sizes"] = value.split()
        elif sep and key == "NUMBER OF SIZES":
            out["number_of_sizes"] = value.strip()
        elif sep and key == "SAMPLE SIZE":
            out["sample_size"] = value.strip()
        elif sep and key == "UNITS":
            if value.strip().upper() not in RUL_UNITS:
                raise PatternError(f"{where}: UNITS {value.strip()!r} (line {lineno}); expected METRIC or ENGLISH")
            out["units"] = RUL_UNITS[value.strip().upper()]
        elif sep and key == "RULE":
            close(lineno)
            kind, _, num = value.strip().rpartition(" ")
            if kind.strip().upper() != "DELTA" or not num.isdigit():
                raise PatternError(f"{where}: line {lineno} {line!r}: only 'RULE: DELTA <number>' rules are read")
            if "sizes" not in out:
                raise PatternError(f"{where}: rule {num} (line {lineno}) comes before the SIZE LIST")
            current, moves = int(num), []
            if current in out["rules"]:
                raise PatternError(f"{where}: rule {current} is given twice (line {lineno})")
        elif not sep and current is not None:
            for pair in line.replace(", ", ",").split():
                try:
                    dx, dy = (float(v) for v in pair.split(","))
                except ValueError:
                    raise PatternError(f"{where}: rule {current}, line {lineno}: {pair!r} is not a move 'dx,dy'") from None
                if not (np.isfinite(dx) and np.isfinite(dy)):
                    raise PatternError(f"{where}: rule {current}, line {lineno}: move {pair!r} is not finite")
                moves.append([dx, dy])
            if len(moves) > len(out["sizes"]):
                raise PatternError(f"{where}: rule {current} has more moves than the SIZE LIST's "
                                   f"{len(out['sizes'])} sizes (line {lineno})")
        elif not sep:
            raise PatternError(f"{where}: line {lineno} {line[:40]!r} is neither a header line nor in a rule")
    close(lineno)
    for key, what in (("sizes", "SIZE LIST"), ("sample_size", "SAMPLE SIZE"), ("units", "UNITS")):
        if key not in out:
            raise PatternError(f"{where}: no {what} line; not a RUL grade-rule table")
    if "number_of_sizes" in out and out.pop("number_of_sizes") != str(len(out["sizes"])):
        raise PatternError(f"{where}: NUMBER OF SIZES does not match the {len(out['sizes'])} sizes of the SIZE LIST")
    if out["sample_size"] not in out["sizes"]:
        raise PatternError(f"{where}: SAMPLE SIZE {out['sample_size']!r} is not in the SIZE LIST "
                           f"({' '.join(out['sizes'])})")
    return out


def write_graded_dxf(path, rul_path, patterns: Sequence[Pattern], labels: Sequence[str], base_index: int, *,
                     units: str = "mm") -> tuple[Path, Path]:
    """The base size as DXF-ASTM with a ``# n`` grade-rule text at each grade point, and its
    RUL table at ``rul_path`` (see the module's text)."""
    path, rul_path = Path(path), Path(rul_path)
    rules, points = grade_rules(patterns, labels, base_index, units=units)
    base = copy.deepcopy(patterns[base_index])
    header = dict((base.extra.get("dxf") or {}).get("header") or {})
    header["sample_size"] = labels[base_index]
    base.extra["dxf"] = {**(base.extra.get("dxf") or {}), "header": header}
    for panel in base.panels:
        panel.extra["size"] = labels[base_index]
    doc = build_dxf(base, flavor="astm", units=units, name=path.name)
    k_units = 1.0 / UNITS_CM[units]
    for panel, ref in zip(base.panels, doc.modelspace().query("INSERT")):
        blk = doc.blocks.get(ref.dxf.name)
        o = np.asarray(panel.outline_cm, dtype=float)
        h = 0.3 * k_units
        for i, r in points[panel.name].items():
            blk.add_text(f"# {r + 1}", height=h, dxfattribs={"layer": "1", "insert": (o[i, 0] * k_units, o[i, 1] * k_units)})
    _write(doc, path)
    atomic_write_text(rul_path, format_rul(rules, labels, base_index, name=path.stem, units=units))
    return path, rul_path


# ============================================================================ reading

@dataclasses.dataclass
class DxfSizes:
    """A DXF's pieces grouped by size: ``patterns`` maps each size, in file order, to its
    pattern (one entry, keyed None, when no piece names a size); ``sample_size`` is the
    header's ``Sample Size:`` when it names one of them; ``rul`` the RUL table the sizes were
    graded by (seamfit.pattern.dxf_graded), if they were."""
    path: Path
    patterns: dict[str | None, Pattern]
    sample_size: str | None
    flavor: str
    units: str
    notes: list[str]
    rul: Path | None = None

    @property
    def labels(self) -> list[str]:
        return [lab for lab in self.patterns if lab is not None]


def read_dxf_sizes(path, *, units: str | None = None) -> DxfSizes:
    """The DXF at ``path`` as one pattern per size (each piece's ``Size:`` text), piece names
    unique within each size. A file whose pieces name two sizes or more and where some
    piece names none is a PatternError naming that piece."""
    path = Path(path)
    res = read_dxf_pieces(path, units=units)
    whole = res.pattern
    labels: list[str] = []
    for panel in whole.panels:
        lab = panel.extra.get("size")
        if lab is not None and str(lab) not in labels:
            labels.append(str(lab))
    groups: dict[str | None, list] = {}
    if len(labels) < 2:
        groups[labels[0] if labels else None] = whole.panels
    else:
        for panel in whole.panels:
            if panel.extra.get("size") is None:
                raise PatternError(f"{path}: piece {panel.name!r} has no Size text, but the file's other pieces "
                                   f"name {len(labels)} sizes ({', '.join(labels)}): each piece of a multi-size "
                                   "file needs its size")
            groups.setdefault(str(panel.extra["size"]), []).append(panel)
    patterns = {}
    for lab, panels in groups.items():
        unique_names(panels)
        pat = dataclasses.replace(whole, panels=list(panels), stitches=[], extra=copy.deepcopy(whole.extra))
        if lab is not None:
            pat.extra["size"] = lab
        patterns[lab] = pat
    sample = ((whole.extra.get("dxf") or {}).get("header") or {}).get("sample_size")
    return DxfSizes(path=path, patterns=patterns, sample_size=sample if sample in patterns else None,
                    flavor=res.flavor, units=res.units, notes=res.notes)


def size_notes(sizes: DxfSizes, label: str | None) -> list[str]:
    """The reader's notes on one size: those naming its pieces (``(size NAME)``), and those
    on the file as a whole."""
    if len(sizes.patterns) < 2:
        return list(sizes.notes)
    return [m for m in sizes.notes if f"(size {label})" in m or "(size " not in m]


def one_size(sizes: DxfSizes, size: str | None) -> Pattern:
    """The pattern of ``size``; without one, the file's only pattern. PatternError listing
    the sizes when the file holds several and none is chosen, or not the one chosen."""
    listed = ", ".join(sizes.labels)
    if size is None:
        if len(sizes.patterns) > 1:
            sample = f"; sample size {sizes.sample_size}" if sizes.sample_size else ""
            what = (f"a base DXF graded by {sizes.rul.name} to" if sizes.rul is not None
                    else "a multi-size DXF holding")
            rul = f" --rul {sizes.rul.name}" if sizes.rul is not None else ""
            raise PatternError(f"{sizes.path}: {what} {len(sizes.patterns)} sizes ({listed}"
                               f"{sample}); choose one with --size NAME (convert, validate), or for the other "
                               f"commands write it out first: seamfit convert {sizes.path.name}{rul} --size NAME "
                               "--out NAME.json")
        return next(iter(sizes.patterns.values()))
    if size not in sizes.patterns:
        held = f"holds sizes {listed}" if sizes.labels else "names no size (no piece has a Size text)"
        raise PatternError(f"{sizes.path}: no size {size!r}; the file {held}")
    return sizes.patterns[size]
