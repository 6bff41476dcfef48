"""A DXF pattern through grading: the pencil skirt written as DXF-ASTM (with its seams
sidecar, notches and a grain line), read back, graded to size 10 at a coarse setting,
written as DXF-AAMA with a seam allowance, and read again."""
from __future__ import annotations

import copy
import json

import ezdxf
import numpy as np

from seamfit.cli import main
from seamfit.pattern import load_pattern, save_pattern
from seamfit.pattern.dxf import read_dxf_file
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"


def test_read_grade_write_read(tmp_path):
    base = load_pattern(PATTERN)
    marked = copy.deepcopy(base)
    for pn in marked.panels:                    # a notch at the middle of every stitch side, a grain line
        n = pn.n_vertices
        mids = sorted({(s.range[0] + ((s.range[1] - s.range[0]) % n) // 2) % n
                       for st in marked.stitches for s in (st.a, st.b) if s.panel == pn.name})
        pn.extra["notches"] = [{"vertex": v, "type": "slit", "depth_cm": 0.6} for v in mids]
        lo, hi = pn.outline_cm.min(axis=0), pn.outline_cm.max(axis=0)
        pn.extra["grain_line_cm"] = [[float(lo[0] + hi[0]) / 2, float(lo[1]) + 1.0], [float(lo[0] + hi[0]) / 2, float(hi[1]) - 1.0]]
    src = tmp_path / "marked.json"
    save_pattern(marked, src)

    dxf = tmp_path / "skirt.astm.dxf"
    assert main(["convert", str(src), "--out", str(dxf), "-q"]) == 0
    read = load_pattern(dxf)                    # with skirt.seams.json beside it
    assert len(read.stitches) == len(base.stitches) and read.garment_type == base.garment_type

    out = tmp_path / "graded"
    assert main(["grade", str(dxf), "--base-body", str(B0), "--target-body", str(B1), "--out", str(out),
                 "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "2",
                 "--checkpoint-every", "1", "--no-picture", "-q"]) == 0
    graded = load_pattern(out / "pattern.json")
    moved = max(float(np.abs(g.outline_cm - b.outline_cm).max()) for g, b in zip(graded.panels, read.panels))
    assert moved > 0.1                           # the grading moved the outline (cm)

    final = tmp_path / "skirt_size10.aama.dxf"
    assert main(["convert", str(out / "pattern.json"), "--out", str(final), "--seam-allowance", "1", "-q"]) == 0
    doc = ezdxf.readfile(final)
    assert not doc.audit().has_errors
    back = read_dxf_file(final).pattern
    assert [p.name for p in back.panels] == [p.name for p in graded.panels]
    for g, b in zip(graded.panels, back.panels):
        np.testing.assert_allclose(b.outline_cm, g.outline_cm, atol=1e-6)
        assert [x["vertex"] for x in b.extra["notches"]] == [x["vertex"] for x in g.extra["notches"]]
        np.testing.assert_allclose(b.extra["grain_line_cm"], g.extra["grain_line_cm"], atol=1e-9)
        assert b.extra["dxf"]["cut_line_cm"]     # the seam allowance is on the cut line (layer 1)
        # measured back from the file: 1 cm along the seams (darts fold the cut line on itself)
        assert abs(np.median([e.extra["seam_allowance_cm"] for e in b.edges]) - 1.0) < 0.01
    # and its stitches come back from the sidecar written beside it
    side = json.loads((tmp_path / "skirt_size10.seams.json").read_text())
    assert sum(s["confirmed"] for s in side["stitches"]) == len(base.stitches)
    assert len(load_pattern(final).stitches) == len(base.stitches)
