"""``seamfit validate``: summary and exit codes for patterns, missing and unknown files."""
from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from seamfit import cli
from seamfit.pattern import load_pattern, save_pattern
from common import SAMPLES, command_runner

PATTERNS = SAMPLES / "patterns"
PENCIL = PATTERNS / "gc_pencil_skirt/size06/pattern.json"
GC_SPEC = PATTERNS / "gc_pencil_skirt/size06/native/gc_pencil_skirt_specification.json"


@pytest.fixture
def run(monkeypatch, capsys):
    return command_runner(monkeypatch, capsys, "validate")


def test_valid_sewpat_prints_summary(run):
    code, out, err = run(PENCIL)
    assert code == 0 and err == ""
    assert f"{PENCIL}: sewpat-1 (garment gc_pencil_skirt, body size06)" in out
    assert "panels: 4, vertices: 757, stitches: 20 (2 gathered), warnings: 0, errors: 0" in out
    assert "- skirt_back: 339 vertices, 18 edges, 16 corners" in out
    assert out.rstrip().endswith("OK")


def test_valid_garmentcode_spec(run):
    code, out, _ = run(GC_SPEC)
    assert code == 0
    assert "GarmentCode specification (garment gc_pencil_skirt)" in out
    assert "panels: 4, vertices: 757, stitches: 20" in out


def test_invalid_pattern_exits_1_and_lists_errors(run, tmp_path):
    p = copy.deepcopy(load_pattern(PENCIL))
    p.stitches[5].b.range = (0, 10_000)
    p.panels[0].outline_cm = p.panels[0].outline_cm.copy()
    p.panels[0].outline_cm[3] = p.panels[0].outline_cm[2]
    bad = save_pattern(p, tmp_path / "bad.json")
    code, out, err = run(bad)
    assert code == 1
    assert "errors: 2" in out and out.rstrip().endswith("INVALID")
    assert "error: " in err and "stitch 5 (dart_or_internal) side b" in err and "vertex 10000" in err
    assert "panel 'skirt_back'" in err and "vertices 2-3" in err


def test_warning_fails_only_when_strict(run, tmp_path):
    p = copy.deepcopy(load_pattern(PENCIL))
    p.panels[1].outline_cm = np.vstack([p.panels[1].outline_cm, p.panels[1].outline_cm[:1]])
    path = save_pattern(p, tmp_path / "dup.json")
    code, out, _ = run(path)
    assert code == 0 and "warning: " in out and "repeats vertex 0" in out
    code, _, _ = run(path, "--strict")
    assert code == 1
    fixed = tmp_path / "fixed.json"
    code, out, _ = run(path, "--fix", fixed, "--strict")
    assert code == 1                                  # the input still has the warning
    assert "fixed: " in out and fixed.exists()
    code, out, _ = run(fixed, "--strict")
    assert code == 0 and "warnings: 0" in out


def test_seam_tolerance_option(run, tmp_path):
    p = copy.deepcopy(load_pattern(PENCIL))
    for s in p.stitches:
        s.gathered = False                           # the ~1 cm eased side seams now count
    path = save_pattern(p, tmp_path / "eased.json")
    assert run(path)[0] == 1
    assert run(path, "--seam-tolerance", "1.5")[0] == 0
    assert run(path, "--seam-tolerance", "-1")[0] == 2


def test_svg_option(run, tmp_path):
    svg = tmp_path / "out.svg"
    code, out, _ = run(PENCIL, "--svg", svg, "--quiet")
    assert code == 0 and out.strip() == f"wrote {svg}"
    root = ET.parse(svg).getroot()
    assert root.get("width").endswith("cm")


@pytest.mark.parametrize("name, content, message", [
    ("nothere.json", None, "nothere.json: no such file"),
    ("nothere.obj", None, "nothere.obj: no such file"),
    ("notes.txt", "hello", "notes.txt: unsupported file type '.txt'"),
    ("broken.json", "{", "broken.json: invalid JSON"),
    ("other.json", '{"a": 1}', "other.json: JSON file is not a pattern"),
])
def test_unreadable_files_exit_2(run, tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    code, out, err = run(path)
    assert code == 2 and out == ""
    assert err.startswith("seamfit validate: error: ") and message in err
    assert "Traceback" not in err


def test_help_documents_everything(run, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["validate", "--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    for word in ("FILE", "sewpat-1", "GarmentCode", ".obj", ".ply", "--seam-tolerance", "--seam-tolerance-rel",
                 "--strict", "--svg", "--fix", "--quiet", "exit status", "self-intersections", "units"):
        assert word in text, word
