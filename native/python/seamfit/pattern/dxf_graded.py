"""The graded form of a size run read back: a base-size DXF whose grade points carry rule
numbers, with its RUL grade-rule table, as one pattern per size (docs/formats.md, "Size runs").

ASTM D6673 (and AAMA before it) grades a base pattern by rules: each grade point on the base
piece carries a rule number, a ``# n`` TEXT whose insertion point is the point (seamfit's
``write_graded_dxf`` writes them on layer 1; any layer is read), and the RUL table lists per
rule each size's move (dx, dy) from the sample size. A size is made as graders make it:

* each grade point moves by its rule's move for that size;
* every outline point between two grade points moves by the two moves blended in proportion
  to its arc length along the base outline between them (one grade point: the piece moves
  with it; none: the piece is the same in every size);
* the edges are fitted again between the base's corners and curve points, as the DXF reader
  maps an outline (``build_panel_geometry``), notches and landmarks staying on their points;
* points inside the piece without a rule of their own (grain line, drill holes, internal
  lines, cutouts, texts) move by the grade points' moves weighted by inverse squared
  distance; the grain line keeps its direction (it moves by its midpoint's move).

The sample size is the base as read. A graded size's cut line is rebuilt on writing from
each edge's seam allowance, measured on the base.
"""
from __future__ import annotations

import copy
import dataclasses
import re
from pathlib import Path

import numpy as np

from ..errors import PatternError
from .allowance import MITRE_LIMIT
from .dxf import UNITS_CM, build_panel_geometry, read_dxf_file
from .dxf_sizes import DxfSizes, parse_rul
from .model import Panel, Pattern

RULE_TEXT = re.compile(r"#\s*(\d+)")
ON_POINT_CM = 0.01          # a rule number's text sits within 0.1 mm of its grade point
_METRIC = ("mm", "cm", "m")


def read_rul(path) -> dict:
    """The RUL table at ``path`` (see dxf_sizes.parse_rul); PatternError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise PatternError(f"{path}: no such RUL grade-rule table")
    try:
        text = path.read_text(encoding="cp1252", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise PatternError(f"{path}: cannot read the RUL grade-rule table ({type(exc).__name__})") from None
    return parse_rul(text, where=str(path))


def read_graded_dxf(path, rul_path, *, units: str | None = None) -> DxfSizes:
    """The base DXF at ``path`` graded by the RUL table at ``rul_path``: one pattern per size
    of the table's SIZE LIST, in its order. PatternError (one line, naming the file, piece
    and rule) for a rule number the table lacks, a rule text off the piece's outline, a
    DXF that already holds several sizes, a sample size the two files disagree on, or units
    of different systems (a metric DXF needs METRIC rules, an inch DXF ENGLISH)."""
    path, rul_path = Path(path), Path(rul_path)
    table = read_rul(rul_path)
    res = read_dxf_file(path, units=units)
    base = res.pattern
    if (res.units in _METRIC) != (table["units"] == "mm"):
        raise PatternError(f"{rul_path}: UNITS {'METRIC' if table['units'] == 'mm' else 'ENGLISH'} but {path.name} "
                           f"is in {res.units}; the rules and the base pattern need the same unit system")
    labels = {str(p.extra["size"]) for p in base.panels if p.extra.get("size") is not None}
    if len(labels) > 1:
        raise PatternError(f"{path}: holds {len(labels)} sizes ({', '.join(sorted(labels))}); grade rules apply "
                           "to a base DXF of one size")
    sample = table["sample_size"]
    declared = ((base.extra.get("dxf") or {}).get("header") or {}).get("sample_size") or next(iter(labels), None)
    if declared is not None and str(declared).replace(" ", "_") != sample:
        raise PatternError(f"{path}: sample size {declared!r}, but {rul_path.name}'s SAMPLE SIZE is {sample!r}")
    to_cm = UNITS_CM[table["units"]]
    k_sample = table["sizes"].index(sample)
    graded = []          # per panel: (grade vertices, rule numbers)
    notes = list(res.notes)
    for panel in base.panels:
        graded.append(_grade_points(panel, table, path, rul_path, notes))
    bare = [p.name for p, (idx, _) in zip(base.panels, graded) if not idx]
    if bare:
        notes.append(f"{path}: piece(s) {', '.join(map(repr, bare))} carry no grade rule; the same in every size")
    patterns: dict[str | None, Pattern] = {}
    for k, label in enumerate(table["sizes"]):
        pat = copy.deepcopy(base)
        pat.extra["size"] = label
        header = dict((pat.extra.get("dxf") or {}).get("header") or {})
        header["sample_size"] = sample
        pat.extra["dxf"] = {**(pat.extra.get("dxf") or {}), "header": header}
        pat.extra.setdefault("source", {})["grade_rules"] = rul_path.name
        for j, (idx, rules) in enumerate(graded):
            moves = np.array([table["rules"][r][k] for r in rules]).reshape(-1, 2) * to_cm
            if k != k_sample:
                pat.panels[j] = grade_panel(pat.panels[j], idx, moves)
            pat.panels[j].extra["size"] = label
        patterns[label] = pat
    return DxfSizes(path=path, patterns=patterns, sample_size=sample, flavor=res.flavor, units=res.units,
                    notes=notes, rul=rul_path)


def _grade_points(panel: Panel, table: dict, path: Path, rul_path: Path,
                  notes: list[str]) -> tuple[list[int], list[int]]:
    """The panel's grade points (outline vertices) and their rule numbers, from its ``# n``
    texts, which are taken out of the panel's texts. A rule on the cut line (AAMA's boundary)
    goes to the seam line's nearest edge end, the allowance moving with it, unless that point
    has a rule of its own; a note says how many."""
    dxf = panel.extra.get("dxf") if isinstance(panel.extra.get("dxf"), dict) else {}
    o = np.asarray(panel.outline_cm, dtype=float)
    cut = np.asarray(dxf.get("cut_line_cm") or np.zeros((0, 2)), dtype=float).reshape(-1, 2)
    allowance = max((float(e.extra.get("seam_allowance_cm") or 0.0) for e in panel.edges), default=0.0)
    ends = sorted(set(int(i) for i in panel.nodes) | set(int(i) for i in panel.corners))
    rules, kept = [], []
    for t in dxf.get("texts") or []:
        m = RULE_TEXT.fullmatch(str(t.get("text", "")).strip())
        if m:
            p = np.asarray(t["at_cm"], dtype=float)
            rules.append((float(np.linalg.norm(o - p, axis=1).min()) > ON_POINT_CM, int(m.group(1)), p))
        else:
            kept.append(t)
    at: dict[int, int] = {}
    on_cut = 0
    for off_seam, r, p in sorted(rules, key=lambda x: x[0]):        # the seam line's own rules first
        where = f"{path}: piece {panel.name!r}: grade rule # {r} at ({p[0]:.2f}, {p[1]:.2f}) cm"
        if r not in table["rules"]:
            raise PatternError(f"{where}: no rule {r} in {rul_path.name} (its rules: "
                               f"{_ranges(sorted(table['rules']))})")
        d = np.linalg.norm(o - p, axis=1)
        i = int(np.argmin(d))
        if off_seam:
            if not (len(cut) and float(np.linalg.norm(cut - p, axis=1).min()) <= ON_POINT_CM and ends):
                raise PatternError(f"{where} is {d[i] * 10:.2f} mm from the nearest outline point; a rule number "
                                   "sits on its grade point of the seam or cut line")
            de = np.linalg.norm(o[ends] - p, axis=1)
            i = ends[int(np.argmin(de))]
            if float(de.min()) > MITRE_LIMIT * allowance + ON_POINT_CM:
                raise PatternError(f"{where} is on the cut line, {float(de.min()) * 10:.1f} mm from the seam "
                                   f"line's nearest edge end, more than {MITRE_LIMIT:g} seam allowances")
            on_cut += 1
            at.setdefault(i, r)
            continue
        if at.get(i, r) != r:
            raise PatternError(f"{where}: the point already carries rule {at[i]}")
        at[i] = r
    if dxf:
        dxf["texts"] = kept
    if on_cut:
        notes.append(f"{path}: piece {panel.name!r}: {on_cut} grade rule(s) on the cut line, each applied to the "
                     "seam line's nearest edge end")
    idx = sorted(at)
    return idx, [at[i] for i in idx]


def _ranges(nums: list[int]) -> str:
    if not nums:
        return "none"
    out, lo = [], nums[0]
    for a, b in zip(nums, nums[1:] + [None]):
        if b != a + 1:
            out.append(f"{lo}" if lo == a else f"{lo}-{a}")
            lo = b
    return ", ".join(out)


def proportional_moves(o: np.ndarray, idx: list[int], moves: np.ndarray) -> np.ndarray:
    """Each outline point's move: grade point ``idx[j]`` moves by ``moves[j]``; the points
    between two grade points by the two moves blended in proportion to arc length."""
    n = len(o)
    out = np.zeros((n, 2))
    if not idx:
        return out
    if len(idx) == 1:
        return np.tile(moves[0], (n, 1))
    seg = np.linalg.norm(np.roll(o, -1, axis=0) - o, axis=1)
    for j, a in enumerate(idx):
        b = idx[(j + 1) % len(idx)]
        run = (a + np.arange((b - a) % n + 1)) % n
        s = np.concatenate([[0.0], np.cumsum(seg[run[:-1]])])
        t = s / s[-1] if s[-1] > 0 else np.zeros_like(s)
        out[run] = (1.0 - t)[:, None] * moves[j] + t[:, None] * moves[(j + 1) % len(idx)]
    return out


def grade_panel(panel: Panel, idx: list[int], moves: np.ndarray) -> Panel:
    """The panel of one size: see the module's text."""
    o = np.asarray(panel.outline_cm, dtype=float)
    new = o + proportional_moves(o, idx, moves)
    outline, edges, nodes, corners, new_index = build_panel_geometry(new, list(panel.corners), list(panel.nodes))
    old_edges = {int(new_index[e.start]): e for e in panel.edges}
    for e in edges:
        was = old_edges.get(e.start)
        if was is not None:
            e.extra.update({k: v for k, v in was.extra.items() if not k.startswith("_")})
    out = dataclasses.replace(panel, outline_cm=outline, edges=edges, nodes=nodes, corners=corners,
                              extra=copy.deepcopy(panel.extra))
    out.orientation = "ccw" if out.signed_area_cm2() > 0 else "cw"
    out.landmarks = {name: ([int(new_index[i]) for i in v] if isinstance(v, (list, tuple)) else int(new_index[v]))
                     for name, v in panel.landmarks.items()}
    for notch in out.extra.get("notches") or []:
        notch["vertex"] = int(new_index[int(notch["vertex"])])
    g = o[idx] if idx else np.zeros((0, 2))

    def move(points) -> np.ndarray:
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        if not len(g):
            return p
        w = 1.0 / np.maximum(((p[:, None, :] - g[None]) ** 2).sum(-1), 1e-12)
        return p + (w @ moves) / w.sum(axis=1, keepdims=True)

    ex = out.extra
    if ex.get("grain_line_cm"):
        gl = np.asarray(ex["grain_line_cm"], dtype=float)
        ex["grain_line_cm"] = (gl + (move(gl.mean(axis=0)) - gl.mean(axis=0))).tolist()
    if ex.get("drill_holes_cm"):
        ex["drill_holes_cm"] = move(ex["drill_holes_cm"]).tolist()
    for line in ex.get("internal_lines") or []:
        line["points_cm"] = move(line["points_cm"]).tolist()
    if ex.get("cutouts"):
        ex["cutouts"] = [move(c).tolist() for c in ex["cutouts"]]
    dxf = ex.get("dxf") if isinstance(ex.get("dxf"), dict) else None
    if dxf is not None:
        for t in dxf.get("texts") or []:
            t["at_cm"] = move(t["at_cm"])[0].tolist()
        dxf.pop("cut_line_cm", None)             # rebuilt from the edges' allowances on writing
        dxf.pop("seam_line_sha1", None)
    return out
