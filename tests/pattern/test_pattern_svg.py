"""SVG output: true scale, labels, overlay nest; checked by parsing the file."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import load_pattern, write_svg
from common import SAMPLES

PATTERNS = SAMPLES / "patterns"
NS = {"s": "http://www.w3.org/2000/svg"}


def _path_points(el) -> np.ndarray:
    nums = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", el.get("d"))]
    return np.array(nums).reshape(-1, 2)


def _panel_groups(pattern_group) -> dict[str, ET.Element]:
    return {g.get("data-panel"): g for g in pattern_group.findall("s:g[@class='panel']", NS)}


@pytest.fixture(scope="module")
def bodice():
    return load_pattern(PATTERNS / "fs_bodice/size06/pattern.json")


@pytest.fixture(scope="module")
def skirts():
    return [load_pattern(PATTERNS / f"gc_pencil_skirt/{b}/pattern.json") for b in ("size06", "size10", "apple")]


def test_single_pattern_true_scale_and_labels(tmp_path, bodice):
    out = write_svg(tmp_path / "bodice.svg", bodice, title="bodice")
    root = ET.parse(out).getroot()
    # 1 user unit = 1 cm: width/height in cm equal the viewBox size
    w, h = root.get("width"), root.get("height")
    assert w.endswith("cm") and h.endswith("cm")
    vb = [float(x) for x in root.get("viewBox").split()]
    assert vb[:2] == [0, 0] and vb[2] == pytest.approx(float(w[:-2])) and vb[3] == pytest.approx(float(h[:-2]))

    groups = root.findall("s:g[@class='pattern']", NS)
    assert len(groups) == 1
    panels = _panel_groups(groups[0])
    assert set(panels) == {p.name for p in bodice.panels}
    for p in bodice.panels:
        g = panels[p.name]
        pts = _path_points(g.find("s:path[@class='outline']", NS))
        assert len(pts) == p.n_vertices
        o = p.outline_cm
        # extent of the drawn path equals the outline's bounding box in cm
        assert np.allclose(pts.max(axis=0) - pts.min(axis=0), o.max(axis=0) - o.min(axis=0), atol=2e-3)
        # v up on the sheet: the vertex with the largest v is drawn highest (smallest y)
        assert pts[np.argmax(o[:, 1]), 1] == pytest.approx(pts[:, 1].min(), abs=2e-3)
        # the drawing is the outline up to a shift
        assert np.allclose(pts[:, 0] - o[:, 0], pts[0, 0] - o[0, 0], atol=2e-3)
        assert np.allclose(pts[:, 1] + o[:, 1], pts[0, 1] + o[0, 1], atol=2e-3)
        assert g.find("s:text[@class='panel-name']", NS).text == p.name
        assert len(g.findall("s:g[@class='corners']/s:circle", NS)) == len(p.corners)
        ends = {i for s in bodice.stitches for side in (s.a, s.b) if side.panel == p.name for i in side.range}
        assert len(g.findall("s:g[@class='notches']/s:line", NS)) == len(ends)
        # stays on the sheet
        assert pts.min() >= 0 and pts[:, 0].max() <= vb[2] and pts[:, 1].max() <= vb[3]

    # every stitch is labelled once on each side, on the panel that side belongs to
    labels = root.findall(".//s:text[@class='stitch-label']", NS)
    assert len(labels) == 2 * len(bodice.stitches)
    for k, s in enumerate(bodice.stitches):
        for tag, side in (("a", s.a), ("b", s.b)):
            el = panels[side.panel].find(f"s:g/s:text[@data-stitch='{k}'][@data-side='{tag}']", NS)
            assert el is not None and el.text == str(k)
    assert root.find("s:title", NS).text == "bodice"


def test_panels_do_not_overlap(tmp_path, skirts):
    root = ET.parse(write_svg(tmp_path / "s.svg", skirts)).getroot()
    boxes = {}
    for g in root.findall("s:g[@class='pattern']", NS):
        for name, pg in _panel_groups(g).items():
            pts = _path_points(pg.find("s:path", NS))
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            blo, bhi = boxes.get(name, (lo, hi))
            boxes[name] = (np.minimum(lo, blo), np.maximum(hi, bhi))
    names = list(boxes)
    assert len(names) == 4
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            (alo, ahi), (blo, bhi) = boxes[names[i]], boxes[names[j]]
            assert np.any(ahi < blo) or np.any(bhi < alo), (names[i], names[j])


def test_overlay_nest(tmp_path, skirts):
    out = write_svg(tmp_path / "nest.svg", skirts, labels=["size 06", "size 10", "apple"], title="nest")
    root = ET.parse(out).getroot()
    groups = {g.get("id"): g for g in root.findall("s:g[@class='pattern']", NS)}
    assert set(groups) == {"pattern-0", "pattern-1", "pattern-2"}
    colors = [groups[f"pattern-{k}"].get("data-color") for k in range(3)]
    assert colors[0] == "#000000" and len(set(colors)) == 3
    for k, g in groups.items():
        for path in g.findall(".//s:path", NS):
            assert path.get("stroke") == g.get("data-color")
    # legend: one entry per pattern, in its colour, with its label
    entries = root.findall("s:g[@id='legend']/s:g", NS)
    assert [e.find("s:text", NS).text for e in entries] == ["size 06 (base)", "size 10", "apple"]
    assert [e.find("s:line", NS).get("stroke") for e in entries] == colors
    # each graded panel is aligned at its bounding-box top-centre with the base panel
    base = _panel_groups(groups["pattern-0"])
    for k in (1, 2):
        for name, pg in _panel_groups(groups[f"pattern-{k}"]).items():
            a = _path_points(base[name].find("s:path", NS))
            b = _path_points(pg.find("s:path", NS))
            top_a = [(a[:, 0].min() + a[:, 0].max()) / 2, a[:, 1].min()]
            top_b = [(b[:, 0].min() + b[:, 0].max()) / 2, b[:, 1].min()]
            assert np.allclose(top_a, top_b, atol=2e-3), (k, name)
            # and drawn at its own size: the sizes differ from the base
            o = next(p for p in skirts[k].panels if p.name == name).outline_cm
            assert np.allclose(b.max(axis=0) - b.min(axis=0), o.max(axis=0) - o.min(axis=0), atol=2e-3)
    # labels (panel names, stitch numbers) are drawn once, for the base
    assert len(root.findall(".//s:text[@class='panel-name']", NS)) == len(skirts[0].panels)


def test_many_overlays_get_distinct_colours(tmp_path, skirts):
    pats = [skirts[k % 3] for k in range(8)]
    root = ET.parse(write_svg(tmp_path / "many.svg", pats)).getroot()
    colors = [g.get("data-color") for g in root.findall("s:g[@class='pattern']", NS)]
    assert len(set(colors)) == 8


def test_svg_errors(tmp_path, bodice):
    with pytest.raises(PatternError, match="1 label"):
        write_svg(tmp_path / "x.svg", [bodice, bodice], labels=["one"])
    with pytest.raises(PatternError, match="no pattern"):
        write_svg(tmp_path / "x.svg", [])
    src = tmp_path / "p.json"
    src.write_text("{}")
    clone = load_pattern(PATTERNS / "fs_bodice/size06/pattern.json")
    clone.source_file = str(src)
    with pytest.raises(PatternError, match="input pattern file"):
        write_svg(src, clone)
    assert src.read_text() == "{}"


def test_nest_png_draws_every_pattern_in_its_colour(tmp_path, skirts):
    import matplotlib.image as mpimg

    from seamfit.pattern.nest_png import render_nest_png
    from seamfit.pattern.svg import OVERLAY_COLORS
    out = render_nest_png(tmp_path / "nest.png", skirts, labels=["size 06", "size 10", "apple"], title="nest")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = mpimg.imread(out)[..., :3]
    # the base's black outlines and both overlay colours are on the picture
    for hex_color in ("#000000", OVERLAY_COLORS[0], OVERLAY_COLORS[1]):
        rgb = np.array([int(hex_color[i:i + 2], 16) / 255 for i in (1, 3, 5)])
        assert (np.abs(img - rgb).max(axis=2) < 0.08).sum() > 200, hex_color
    # no temporary file left behind, and a bad outline names its panel
    assert [p.name for p in tmp_path.iterdir()] == ["nest.png"]
    bad = load_pattern(PATTERNS / "gc_pencil_skirt/size06/pattern.json")
    bad.panels[0].outline_cm[0, 0] = np.nan
    with pytest.raises(PatternError, match=bad.panels[0].name):
        render_nest_png(tmp_path / "bad.png", [bad])
