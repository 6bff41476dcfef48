"""A circle skirt graded through the CLI comes out as circle skirt panels: each skirt panel
an annular sector with the base's angle, its waist as long as the search made it, its side
seams still matched (seamfit.pattern.sectors, run by seamfit.opt.output)."""
import json

import numpy as np
import pytest

from seamfit.cli import main
from seamfit.pattern import load_pattern
from seamfit.pattern.sectors import annular_sectors, fit_circle
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_circle_skirt/size06/pattern.json"
TRUTH = SAMPLES / "patterns/gc_circle_skirt/size10/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    out = tmp_path_factory.mktemp("circle")
    code = main(["grade", str(PATTERN), "--base-body", str(B0), "--target-body", str(B1), "--out", str(out),
                 "--edge-length", "4", "--sdf-spacing", "0.005", "--max-iterations", "16",
                 "--checkpoint-every", "8", "--truth", str(TRUTH), "--no-picture", "-q"])
    assert code == 0
    return load_pattern(out / "pattern.json"), json.loads((out / "report.json").read_text())


def _span(o, centre, run):
    d = o[run] - centre
    a = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    return abs(a[-1] - a[0])


def test_the_skirt_panels_come_out_as_sectors_with_the_base_angle(graded):
    result, rep = graded
    base = load_pattern(PATTERN)
    secs = annular_sectors(base)
    assert set(rep["sectors_trued_mm"]) == {s["panel"] for s in secs}
    for s in secs:
        o = np.asarray(result.panel(s["panel"]).outline_cm, dtype=float)
        ob = np.asarray(base.panel(s["panel"]).outline_cm, dtype=float)
        inner, outer = np.concatenate(s["inner"]), np.concatenate(s["outer"])
        c, r_in, rms_in = fit_circle(o[inner])
        c2, r_out, rms_out = fit_circle(o[outer])
        # on their circles to the written files' 1e-4 cm, about one centre
        assert rms_in < 1e-3 and rms_out < 1e-3 and np.linalg.norm(c - c2) < 0.01
        assert r_in > s["r_in"]                                   # a larger body, a larger waist
        assert _span(o, c, inner) == pytest.approx(_span(ob, s["centre"], inner), abs=1e-4)


def test_the_trued_skirt_keeps_its_seams_and_beats_the_unchanged_pattern(graded):
    _, rep = graded
    assert rep["checks"]["max_seam_mismatch_mm"] < 2.0
    acc = rep["accuracy"]
    assert acc["graded"]["max_cm"] < acc["base_unchanged"]["max_cm"]
