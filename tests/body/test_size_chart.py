"""``seamfit grade-run --size-chart`` on a multi-size table in Valentina's own .vst layout
(tests/data/valentina_women.vst: format 0.4.4, millimetres, a base size and height with
per-step increments, as Valentina writes them): the table's size is read, made into a body
and graded at a coarse setting, and the run's multi-size nest.dxf reads back per size
within 0.1 mm of each size's pattern. A bad value in the table is a one-line error before
any body is made."""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import load_measurement_sets
from seamfit.cli import main
from seamfit.pattern import load_pattern
from seamfit.pattern.dxf_sizes import read_dxf_sizes
from common import DATA, REPO, SHARED_DATA, file_sha256

CHART = DATA / "valentina_women.vst"
PATTERN = REPO / "sample_files/patterns/gc_pencil_skirt/size06/pattern.json"
BODIES = SHARED_DATA / "bodies"
B0 = BODIES / "women_size06.obj"
COARSE = ["--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "4", "--checkpoint-every", "2",
          "--no-picture", "-q"]


def test_the_table_reads_as_valentina_defines_it():
    (size,) = load_measurement_sets(CHART)          # Valentina 0.4.x tables list no sizes: the base size
    assert size.name == "size400"                   # size 40, in the table's millimetres
    assert size.cm == pytest.approx({"height": 164.0, "bust": 88.0, "underbust": 76.0, "waist": 70.0, "hip": 96.0,
                                     "neck": 34.0, "upper_arm": 27.5, "nape_to_waist": 41.0, "shoulder": 39.5,
                                     "waist_to_hip": 20.0, "thigh": 56.0, "inseam": 76.5})
    assert sorted(size.ignored) == ["arm_wrist_circ", "height_waist_side", "neck_circ"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("chart") / "skirt"
    before = [file_sha256(p) for p in (PATTERN, B0, CHART)]
    assert main(["grade-run", str(PATTERN), "--base-body", str(B0), "--size-chart", str(CHART),
                 "--out", str(out), *COARSE]) == 0
    assert [file_sha256(p) for p in (PATTERN, B0, CHART)] == before, "inputs are never modified"
    return out, json.loads((out / "summary.json").read_text())


def test_grade_run_grades_the_table_size(run):
    out, summary = run
    assert sorted(summary["order"]) == ["size400", "women_size06"] and summary["base_size"] == "women_size06"
    row = next(r for r in summary["sizes"] if r["size"] == "size400")
    assert row["folder"] == "size400" and (out / "size400" / "pattern.json").stat().st_size > 0
    rep = json.loads((out / "size400" / "report.json").read_text())
    assert rep["size_run"]["size"] == "size400"


def test_the_run_nest_dxf_reads_back_per_size_within_a_tenth_of_a_millimetre(run):
    out, summary = run
    back = read_dxf_sizes(out / "nest.dxf")
    assert back.labels == summary["order"] and back.sample_size == "women_size06"
    for label in back.labels:
        want = load_pattern(PATTERN if label == "women_size06" else out / label / "pattern.json")
        got = back.patterns[label]
        assert [p.name for p in got.panels] == [p.name for p in want.panels]
        for a, b in zip(want.panels, got.panels):
            # the nest places each size on the sheet; the outline itself is unchanged
            assert len(a.outline_cm) == len(b.outline_cm)
            d = np.abs((b.outline_cm - b.outline_cm[0]) - (a.outline_cm - a.outline_cm[0])).max()
            assert d < 0.01, (label, a.name, d)


def test_a_bad_value_in_the_table_is_one_line_before_any_work(tmp_path, capsys):
    bad = tmp_path / "chart.vst"
    bad.write_text(CHART.read_text().replace('base="960"', 'base="96"'))     # the hip in cm in a mm table
    out = tmp_path / "run"
    assert main(["grade-run", str(PATTERN), "--base-body", str(B0), "--size-chart", str(bad),
                 "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"{bad}: size400: hip = 9.6 cm is outside" in err
    assert not out.exists()
