"""True-scale SVG drawings of patterns, alone or overlaid as a grading nest.

The sheet is in centimetres: the root ``width``/``height`` carry a ``cm`` unit and the
``viewBox`` the same numbers, so one user unit is one centimetre and a printed sheet can
be measured with a ruler. The pattern's v axis points up, the SVG y axis down: y = -v.

Several patterns overlay the way pattern makers check a grading: the first (base) in
black, the others in distinct colours, each panel shifted so that its bounding-box
top-centre meets that of the base panel of the same name.
"""
from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_text
from .model import Panel, Pattern, range_indices

SVG_NS = "http://www.w3.org/2000/svg"
BASE_COLOR = "#000000"
# Colour-blind-safe first (Okabe-Ito), then more; cycled beyond that.
OVERLAY_COLORS = ("#d55e00", "#0072b2", "#009e73", "#cc79a7", "#e69f00", "#56b4e9",
                  "#8c564b", "#7f7f7f", "#bcbd22", "#6a3d9a")

MARGIN_CM = 4.0          # around the sheet and between panels
NAME_FONT_CM = 2.0
STITCH_FONT_CM = 1.2
LEGEND_FONT_CM = 1.6
NOTCH_CM = 1.2           # notch tick length, centred on the outline
CORNER_DOT_CM = 0.3
LINE_CM = 0.1            # outline stroke width (1 mm)


def _f(x: float) -> str:
    s = f"{x:.3f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _label_of(p: Pattern, k: int) -> str:
    if p.body_id:
        return str(p.body_id)
    if p.source_file:
        path = Path(p.source_file)
        return path.parent.name if path.stem == "pattern" else path.stem
    return f"pattern {k}"


def _vertex_normals(o: np.ndarray, ccw: bool) -> np.ndarray:
    """Unit normals pointing into the panel at every outline vertex."""
    d_prev = o - np.roll(o, 1, axis=0)
    d_next = np.roll(o, -1, axis=0) - o
    for d in (d_prev, d_next):
        d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    t = d_prev + d_next
    bad = np.linalg.norm(t, axis=1) < 1e-9              # a hairpin (dart tip): use one side
    t[bad] = d_next[bad]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-12)
    left = np.stack([-t[:, 1], t[:, 0]], axis=1)        # interior is left of a ccw outline
    return left if ccw else -left


def _point_along(o: np.ndarray, idx: np.ndarray, frac: float) -> tuple[np.ndarray, int]:
    """Point at fraction ``frac`` of the arc length of the outline run ``idx``, and the
    vertex nearest to it."""
    pts = o[idx]
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = frac * cum[-1]
    k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, max(len(seg) - 1, 0)))
    if len(seg) == 0 or seg[k] == 0:
        return pts[k], int(idx[k])
    w = (s - cum[k]) / seg[k]
    return pts[k] + w * (pts[k + 1] - pts[k]), int(idx[k] if w < 0.5 else idx[k + 1])


class _Slot:
    """One panel name's place on the sheet; every pattern's copy is aligned in it."""

    def __init__(self, name: str):
        self.name = name
        self.members: list[tuple[int, Panel]] = []   # (pattern index, panel)
        self.lo = np.array([np.inf, np.inf])        # local extent, x right / y down from anchor
        self.hi = -self.lo
        self.origin = np.zeros(2)                   # sheet position of the anchor

    def add(self, k: int, panel: Panel) -> None:
        self.members.append((k, panel))
        x, y = self.local(panel)
        self.lo = np.minimum(self.lo, [x.min(), y.min()])
        self.hi = np.maximum(self.hi, [x.max(), y.max()])

    @staticmethod
    def anchor(panel: Panel) -> np.ndarray:
        o = panel.outline_cm
        return np.array([0.5 * (o[:, 0].min() + o[:, 0].max()), o[:, 1].max()])

    def local(self, panel: Panel, pts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        a = self.anchor(panel)
        p = panel.outline_cm if pts is None else np.atleast_2d(pts)
        return p[:, 0] - a[0], a[1] - p[:, 1]

    def sheet(self, panel: Panel, pts: np.ndarray | None = None) -> np.ndarray:
        x, y = self.local(panel, pts)
        return np.stack([x + self.origin[0], y + self.origin[1]], axis=1)

    @property
    def size(self) -> np.ndarray:
        return self.hi - self.lo


def _layout(slots: list[_Slot], top: float) -> tuple[float, float]:
    """Place slots left to right in rows (shelf packing); returns the sheet size."""
    widths = [s.size[0] for s in slots]
    area = sum(s.size[0] * s.size[1] for s in slots)
    row_width = max(max(widths), 1.5 * math.sqrt(area), 60.0)
    x, y, row_h, sheet_w = MARGIN_CM, top, 0.0, 0.0
    for s in slots:
        w, h = s.size
        if x > MARGIN_CM and x + w > MARGIN_CM + row_width:
            x, y, row_h = MARGIN_CM, y + row_h + MARGIN_CM + NAME_FONT_CM, 0.0
        s.origin = np.array([x - s.lo[0], y - s.lo[1]])
        x += w + MARGIN_CM
        row_h = max(row_h, h)
        sheet_w = max(sheet_w, x)
    return sheet_w, y + row_h + MARGIN_CM


# Characters XML 1.0 cannot hold even escaped (a NUL in a panel name, say): drawn as U+FFFD,
# so that the drawing of any pattern is a well-formed SVG.
_NOT_XML = re.compile("[^\x09\x0a\x0d\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _xml(v) -> str:
    return _NOT_XML.sub("\ufffd", str(v))


def _el(parent, tag: str, **attrs) -> ET.Element:
    return ET.SubElement(parent, tag, {k.rstrip("_").replace("_", "-"): _xml(v)
                                       for k, v in attrs.items()})


def _text(parent, x: float, y: float, text: str, size: float, color: str, cls: str,
          anchor: str = "middle", **attrs) -> ET.Element:
    t = _el(parent, "text", x=_f(x), y=_f(y), font_size=_f(size), fill=color, stroke="none",
            text_anchor=anchor, dominant_baseline="central", font_family="sans-serif",
            class_=cls, **attrs)
    t.text = _xml(text)
    return t


def _draw_panel(g, slot: _Slot, panel: Panel, pattern: Pattern, color: str, base: bool) -> None:
    o = np.asarray(panel.outline_cm, dtype=float)
    sheet = slot.sheet(panel)
    pg = _el(g, "g", class_="panel", data_panel=panel.name)
    d = "M " + " L ".join(f"{_f(x)} {_f(y)}" for x, y in sheet) + " Z"
    _el(pg, "path", class_="outline", d=d, fill="none", stroke=color,
        stroke_width=_f(LINE_CM if base else 0.7 * LINE_CM), stroke_linejoin="round")

    cg = _el(pg, "g", class_="corners", fill=color, stroke="none")
    for i in panel.corners:
        if 0 <= i < len(o):
            x, y = sheet[i]
            _el(cg, "circle", cx=_f(x), cy=_f(y), r=_f(CORNER_DOT_CM), data_vertex=i)

    # the sheet flips v, which turns a ccw outline cw: normals are computed in (u, v)
    normals = _vertex_normals(o, panel.orientation == "ccw") * np.array([1.0, -1.0])
    ng = _el(pg, "g", class_="notches", stroke=color, stroke_width=_f(LINE_CM))
    notched: set[int] = set()
    for s in pattern.stitches:
        for side in (s.a, s.b):
            if side.panel != panel.name:
                continue
            for i in side.range:
                if 0 <= i < len(o) and i not in notched:
                    notched.add(i)
                    p, nv = sheet[i], normals[i] * 0.5 * NOTCH_CM
                    _el(ng, "line", x1=_f(p[0] - nv[0]), y1=_f(p[1] - nv[1]), x2=_f(p[0] + nv[0]),
                        y2=_f(p[1] + nv[1]), data_vertex=i)

    if not base:
        return
    lo, hi = sheet.min(axis=0), sheet.max(axis=0)
    _text(pg, 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), panel.name, NAME_FONT_CM, color,
          "panel-name")
    sg = _el(pg, "g", class_="stitch-labels")
    for si, s in enumerate(pattern.stitches):
        for tag, side in (("a", s.a), ("b", s.b)):
            if side.panel != panel.name or not all(0 <= i < len(o) for i in side.range):
                continue
            p, near = _point_along(o, range_indices(side.range, len(o)), 0.5)
            q = slot.sheet(panel, p)[0] + normals[near] * 1.2 * STITCH_FONT_CM
            _text(sg, q[0], q[1], str(si), STITCH_FONT_CM, color, "stitch-label",
                  data_stitch=si, data_side=tag)


def nest_slots(pats: Sequence[Pattern], labels: Sequence[str] | None):
    """Names and colours of the nested patterns (base black) and one slot per panel name,
    every pattern's copy of that panel in it; refuses outlines that cannot be drawn."""
    names = [str(x) for x in labels] if labels is not None else [_label_of(p, k) for k, p in enumerate(pats)]
    colors = [BASE_COLOR] + [OVERLAY_COLORS[(k - 1) % len(OVERLAY_COLORS)] for k in range(1, len(pats))]
    slots: dict[str, _Slot] = {}
    for k, p in enumerate(pats):
        for panel in p.panels:
            o = np.asarray(panel.outline_cm, dtype=float)
            if o.ndim != 2 or len(o) < 2 or not np.all(np.isfinite(o)):
                raise PatternError(f"{p.source_file or '<pattern>'}: panel {panel.name!r}: outline "
                                   "has too few or non-finite points; cannot draw it")
            slots.setdefault(panel.name, _Slot(panel.name)).add(k, panel)
    return names, colors, list(slots.values())


def write_svg(path: str | Path, patterns: Pattern | Sequence[Pattern], *,
              labels: Sequence[str] | None = None, title: str | None = None) -> Path:
    """Draw one pattern, or several overlaid (the first is the base), to an SVG file at
    true scale (1 user unit = 1 cm). Returns the path written (atomically)."""
    pats = [patterns] if isinstance(patterns, Pattern) else list(patterns)
    if not pats:
        raise PatternError(f"{path}: no pattern to draw")
    if labels is not None and len(labels) != len(pats):
        raise PatternError(f"{path}: {len(labels)} label(s) for {len(pats)} pattern(s)")
    path = Path(path)
    for p in pats:
        if p.source_file and Path(p.source_file).exists() and path.exists() \
                and os.path.samefile(path, p.source_file):
            raise PatternError(f"{path}: is the input pattern file; the SVG is not written over it")
    names, colors, order = nest_slots(pats, labels)

    header = MARGIN_CM + (NAME_FONT_CM * 1.5 if title else 0.0)
    legend_top = header
    top = legend_top + 1.4 * LEGEND_FONT_CM * len(pats) + MARGIN_CM
    width, height = _layout(order, top)
    legend_w = MARGIN_CM + 6.0 + 0.6 * LEGEND_FONT_CM * max(len(n) for n in names) + MARGIN_CM
    width = max(width, legend_w)

    root = ET.Element("svg", {"xmlns": SVG_NS, "version": "1.1", "width": f"{_f(width)}cm",
                              "height": f"{_f(height)}cm", "viewBox": f"0 0 {_f(width)} {_f(height)}"})
    ET.SubElement(root, "title").text = title or "seamfit pattern"
    _el(root, "rect", class_="background", x=0, y=0, width=_f(width), height=_f(height), fill="#ffffff")
    if title:
        _text(root, MARGIN_CM, MARGIN_CM + 0.5 * NAME_FONT_CM, title, 1.2 * NAME_FONT_CM, "#000000",
              "title", anchor="start")
    lg = _el(root, "g", id="legend", class_="legend")
    for k, (name, color) in enumerate(zip(names, colors)):
        y = legend_top + 1.4 * LEGEND_FONT_CM * (k + 0.5)
        eg = _el(lg, "g", class_="legend-entry", data_pattern=k)
        _el(eg, "line", x1=_f(MARGIN_CM), y1=_f(y), x2=_f(MARGIN_CM + 5.0), y2=_f(y), stroke=color,
            stroke_width=_f(3 * LINE_CM))
        _text(eg, MARGIN_CM + 6.0, y, name + (" (base)" if k == 0 and len(pats) > 1 else ""),
              LEGEND_FONT_CM, color, "legend-label", anchor="start")

    # base drawn last so it stays on top of the graded copies
    for k in reversed(range(len(pats))):
        g = _el(root, "g", id=f"pattern-{k}", class_="pattern", data_label=names[k], data_color=colors[k])
        for slot in order:
            for kk, panel in slot.members:
                if kk == k:
                    # names and stitch numbers once per panel: from the base, or from the
                    # first pattern that has the panel when the base has none of that name
                    labelled = k == slot.members[0][0]
                    _draw_panel(g, slot, panel, pats[k], colors[k], base=labelled)
    ET.indent(root)
    text = '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    return atomic_write_text(path, text)
