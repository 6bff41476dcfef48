"""Every command, driven with each bad input a new user tried: a nonzero exit, one line per
problem naming the file (and the panel, stitch, edge, vertex or option at fault), no
traceback, nothing written, and all of it before any expensive work (FAST_S)."""
from __future__ import annotations

import copy
import errno
import json
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import seamfit
from seamfit import cli
from common import SAMPLES

PENCIL = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
GC_SPEC = SAMPLES / "patterns/gc_pencil_skirt/size06/native/gc_pencil_skirt_specification.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
QUICK = ["--edge-length", "5", "--sdf-spacing", "0.01", "--no-picture"]
FAST_S = 5.0   # a refusal takes well under this; meshing, a drape or a grading takes longer


def run(capsys, *argv):
    t0 = time.perf_counter()
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err, time.perf_counter() - t0


def assert_refused(code, err, secs, command, *names, validate_exit=(1, 2)):
    """Nonzero exit, no traceback, every stderr line a one-line message of this command,
    each expected name in the message, and quick."""
    assert code in (validate_exit if command == "validate" else (2,)), (code, err)
    assert "Traceback" not in err and "internal error" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines, "no message"
    prefixes = ((f"seamfit {command}: error: ", f"seamfit {command}: warning: ")
                + (("error: ", "warning: ") if command == "validate" else ()))
    for line in lines:
        assert line.startswith(prefixes), line
    for n in names:
        assert str(n) in err, (n, err)
    assert secs < FAST_S, secs


# A character device: read, it would never end.
A_DEVICE = (lambda tmp: Path("/dev/zero"), ["is a device"])


def pencil() -> dict:
    return json.loads(PENCIL.read_text())


def write(tmp_path: Path, name: str, doc) -> Path:
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return path


# ----------------------------------------------------------------------------- bad patterns
# name -> (make(tmp_path) -> path, what the message names besides the file)

def _self_intersecting(tmp):
    d = pencil()
    o = d["panels"][1]["outline_cm"]
    o[2], o[5] = o[5], o[2]
    return write(tmp, "selfx.json", d)


def _millimetres(tmp):
    d = pencil()
    for p in d["panels"]:
        p["outline_cm"] = [[10 * u, 10 * v] for u, v in p["outline_cm"]]
    return write(tmp, "mm.json", d)


def _stitch_mismatch(tmp):
    d = pencil()
    s = d["stitches"][6]                            # skirt_front [224, 0] to skirt_back [0, 32]
    n = len(d["panels"][3]["outline_cm"])
    s["a"]["range"] = [224, (224 + n // 2) % n]     # a side about 100 cm longer
    return write(tmp, "mismatch.json", d)


def _edit(change, name):
    def make(tmp):
        d = pencil()
        change(d)
        return write(tmp, name, d)
    return make


def _deep(tmp):
    return write(tmp, "deep.json", '{"format": "sewpat-1", "panels": ' + "[" * 100_000 + "]" * 100_000 + "}")


def _big_integer(tmp):
    return write(tmp, "bigint.json", json.dumps(pencil()).replace('"start": 0', '"start": ' + "9" * 5000, 1))


def _null_name(d):
    d["panels"][0]["name"] = None


def _nul_name(d):
    old = d["panels"][0]["name"]
    d["panels"][0]["name"] = "skirt\x00back"
    for s in d["stitches"]:
        for side in (s["a"], s["b"]):
            if side["panel"] == old:
                side["panel"] = "skirt\x00back"


def _many_outline_vertices(tmp):
    # just over the default limit: the self-intersection test and the mesher never see it
    d = pencil()
    t = np.linspace(0, 2 * np.pi, 100_001, endpoint=False)
    p = d["panels"][0]
    p.update(outline_cm=np.round(np.c_[40 * np.cos(t), 40 * np.sin(t)], 4).tolist(), edges=[], nodes=[],
             corners=[], landmarks={})
    d["panels"], d["stitches"] = [p], []
    return write(tmp, "many_vertices.json", d)


def _many_panels(tmp):
    d = pencil()
    band = d["panels"][2]
    d["panels"] = [dict(copy.deepcopy(band), name=f"band{k}") for k in range(501)]
    d["stitches"] = []
    return write(tmp, "many_panels.json", d)


def _gc_far_vertex(tmp):
    d = json.loads(GC_SPEC.read_text())
    d["pattern"]["panels"]["skirt_front"]["vertices"][1] = [1e6, 1e6]
    return write(tmp, "far_specification.json", d)


BAD_PATTERNS = {
    "self-intersecting outline": (_self_intersecting, ["panel 'wb_back'", "self-intersecting outline"]),
    "millimetres read as cm": (_millimetres, ["implausible units", "millimetres"]),
    "107 cm stitch mismatch": (_stitch_mismatch, ["stitch 6 (seam)", "side lengths differ"]),
    "unknown edge kind": (_edit(lambda d: d["panels"][0]["edges"][0].update(kind="spline"), "kind.json"),
                          ["panel 'skirt_back' edge 0 (spline)", "unknown curve kind"]),
    "edge start out of range": (_edit(lambda d: d["panels"][0]["edges"][0].update(start=10**6), "start.json"),
                                ["panel 'skirt_back' edge 0", "1000000", "outside the outline"]),
    "outline as a string": (_edit(lambda d: d["panels"][0].update(outline_cm="0,0 1,1"), "str.json"),
                            ["panel 0 ('skirt_back')", "outline_cm must be a list"]),
    "3-value points": (_edit(lambda d: d["panels"][0].update(
        outline_cm=[[u, v, 0] for u, v in d["panels"][0]["outline_cm"]]), "pts3.json"),
        ["panel 0 ('skirt_back')", "outline_cm item 0 must be 2 numbers"]),
    "stitches not a list": (_edit(lambda d: d.update(stitches={"a": 1}), "stitches.json"),
                            ["stitches must be a list"]),
    "stitch side not an object": (_edit(lambda d: d["stitches"][3].update(a=[1, 2]), "side.json"),
                                  ["stitch 3.a", "expected a JSON object"]),
    "5000-digit integer": (_big_integer, ["5000 digits"]),
    "100k-deep nesting": (_deep, ["nested too deeply"]),
    "1e308 coordinate": (_edit(lambda d: d["panels"][0]["outline_cm"].__setitem__(3, [1e308, 1e308]),
                               "huge.json"), ["panel 'skirt_back'", "outline vertex 3", "1 km"]),
    "null panel name": (_edit(_null_name, "null_name.json"), ["panel 0", "name must be a non-empty string"]),
    "NUL in a panel name": (_edit(_nul_name, "nul_name.json"), ["panel 0 name", "printable characters"]),
    "100,001 outline vertices": (_many_outline_vertices, ["outline vertices", "SEAMFIT_MAX_OUTLINE_VERTICES"]),
    "501 panels": (_many_panels, ["501 panels", "SEAMFIT_MAX_PANELS"]),
    "GarmentCode vertex at 1e6 cm": (_gc_far_vertex, ["panel 'skirt_front'", "SEAMFIT_MAX_OUTLINE_VERTICES"]),
    "a device (/dev/zero)": A_DEVICE,
}


# ----------------------------------------------------------------------------- bad bodies

def _obj_lines() -> list[str]:
    return B0.read_text().splitlines()


def _inverted_lines() -> list[str]:
    return [line if not line.startswith("f ") else "f " + " ".join(reversed(line.split()[1:]))
            for line in _obj_lines()]


_PLY_HEAD = ("ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list {count} int vertex_indices\nend_header\n")


def _ply_binary_negative(tmp):
    path = tmp / "neg.ply"
    path.write_bytes(_PLY_HEAD.format(fmt="binary_little_endian", count="char").encode()
                     + struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 1.7) + struct.pack("<b3i", -1, 0, 1, 2))
    return path


def _ply_ascii_negative(tmp):
    return write(tmp, "neg_ascii.ply", _PLY_HEAD.format(fmt="ascii", count="uchar")
                 + "0 0 0\n1 0 0\n0 1 1.7\n-1 0 1 2\n")


def _huge_coordinates(tmp):
    return write(tmp, "huge.obj", "v 1e308 0 0\nv 0 1e308 0\nv 0 0 1e308\nv 1 1 1\n"
                                  "f 1 2 3\nf 1 2 4\nf 2 3 4\nf 1 3 4\n")


def _negative_element_count(tmp):
    return write(tmp, "neg_count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nproperty float x\n"
                                       "property float y\nproperty float z\nend_header\n")


BAD_BODIES = {
    "PLY list count -1 (binary)": (_ply_binary_negative, ["face", "length -1"]),
    "PLY list count -1 (ascii)": (_ply_ascii_negative, ["PLY line 13", "'face'"]),
    "PLY element count -3": (_negative_element_count, ["PLY header line 3", "negative element count"]),
    "1e308 coordinates": (_huge_coordinates, ["vertex 0", "1000 km) from the origin"]),
    "a device (/dev/zero)": A_DEVICE,
}


# ----------------------------------------------------------------------------- every command, every bad input

# Each command that reads a pattern: its arguments for a pattern and an output path.
PATTERN_COMMANDS = {
    "validate": lambda pattern, out: ["validate", pattern],
    "mesh": lambda pattern, out: ["mesh", pattern, "--out", out, "--edge-length", "4"],
    "drape": lambda pattern, out: ["drape", pattern, B0, "--out", out, "--edge-length", "4"],
    "grade": lambda pattern, out: ["grade", pattern, "--base-body", B0, "--target-body", B1, "--out", out, *QUICK],
}


# Each command that reads a body (grade: as either body): its arguments for a body and an output path.
BODY_COMMANDS = {
    "validate": lambda body, out: ["validate", body],
    "sdf": lambda body, out: ["sdf", body, "--out", out.with_suffix(".npz"), "--spacing", "0.02"],
    "drape": lambda body, out: ["drape", PENCIL, body, "--out", out, *QUICK],
    "grade (base)": lambda body, out: ["grade", PENCIL, "--base-body", body, "--target-body", B1, "--out", out, *QUICK],
    "grade (target)": lambda body, out: ["grade", PENCIL, "--base-body", B0, "--target-body", body, "--out", out,
                                         *QUICK],
}


# Each kind of input: its bad cases and the commands that read it.
KINDS = {"pattern": (BAD_PATTERNS, PATTERN_COMMANDS), "body": (BAD_BODIES, BODY_COMMANDS)}


@pytest.mark.parametrize("kind, command, case", [(kind, command, case) for kind, (cases, commands) in KINDS.items()
                                                 for command in commands for case in cases])
def test_bad_input(tmp_path, capsys, monkeypatch, kind, command, case):
    """The command on the bad input is refused with the expected names in its message, and
    writes nothing."""
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    cases, commands = KINDS[kind]
    make, names = cases[case]
    path = make(tmp_path)
    out = tmp_path / "out"
    code, _, err, secs = run(capsys, *commands[command](path, out))
    assert_refused(code, err, secs, command.split()[0], path, *names)
    assert not out.exists() and not out.with_suffix(".npz").exists() and not list(tmp_path.glob(".out*"))


def test_fifo_inputs_are_refused_not_waited_on(tmp_path):
    """open() on a FIFO blocks until a writer comes: a child process, so a hang fails the test."""
    fifo_pattern, fifo_body = tmp_path / "p.json", tmp_path / "b.obj"
    os.mkfifo(fifo_pattern)
    os.mkfifo(fifo_body)
    here = str(Path(seamfit.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([here] + sys.path), SEAMFIT_CACHE_DIR=str(tmp_path / "c"))
    for argv, fifo in ((["validate", fifo_pattern], fifo_pattern), (["validate", fifo_body], fifo_body),
                       (["mesh", fifo_pattern, "--out", tmp_path / "m"], fifo_pattern),
                       (["sdf", fifo_body, "--out", tmp_path / "s.npz"], fifo_body),
                       (["drape", PENCIL, fifo_body, "--out", tmp_path / "d"], fifo_body),
                       (["grade", PENCIL, "--base-body", B0, "--target-body", B1, "--truth", fifo_pattern,
                         "--out", tmp_path / "g"], fifo_pattern),
                       (["body", "--measurements", fifo_pattern, "--out", tmp_path / "b.obj"], fifo_pattern)):
        proc = subprocess.run([sys.executable, "-m", "seamfit", *map(str, argv)], env=env, cwd=tmp_path,
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
        assert f"{fifo}: is a FIFO (named pipe), not a regular file" in proc.stderr


def test_the_file_size_limit_and_its_override(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SEAMFIT_MAX_FILE_MB", "0")          # 0: no limit
    code, _, err, _ = run(capsys, "validate", PENCIL, "-q")
    assert code == 0, err
    big = tmp_path / "big.obj"
    big.write_bytes(B0.read_bytes() + b"#" * (2 * 2**20))  # a comment makes it 2.8 MB
    monkeypatch.setenv("SEAMFIT_MAX_FILE_MB", "2")
    code, _, err, secs = run(capsys, "sdf", big, "--out", tmp_path / "x.npz")
    assert_refused(code, err, secs, "sdf", big, "2.8 MB", "limit of 2 MB per input file", "SEAMFIT_MAX_FILE_MB")
    monkeypatch.setenv("SEAMFIT_MAX_FILE_MB", "lots")
    code, _, err, secs = run(capsys, "validate", big)
    assert_refused(code, err, secs, "validate", "SEAMFIT_MAX_FILE_MB='lots'", "whole number")


def test_a_limit_is_lifted_by_its_variable(tmp_path, capsys, monkeypatch):
    pattern = _many_panels(tmp_path)
    monkeypatch.setenv("SEAMFIT_MAX_PANELS", "0")
    code, out, err, _ = run(capsys, "validate", pattern)
    assert code == 0 and "panels: 501," in out and "SEAMFIT_MAX_PANELS" not in err, err
    monkeypatch.setenv("SEAMFIT_MAX_PANELS", "3")
    code, _, err, secs = run(capsys, "mesh", PENCIL, "--out", tmp_path / "m")
    assert_refused(code, err, secs, "mesh", PENCIL, "4 panels, more than the limit of 3 panels")


# ----------------------------------------------------------------------------- bad options

BAD_OPTIONS = {
    "mesh": [(["--edge-length", "0.05"], "SEAMFIT_MAX_MESH_VERTICES"), (["--edge-length", "1e-4"], "mesh vertices"),
             (["--edge-length", "nan"], "--edge-length nan")],
    "drape": [(["--edge-length", "0.05"], "SEAMFIT_MAX_MESH_VERTICES"), (["--edge-length", "1e-4"], "mesh vertices"),
              (["--mu", "nan"], "mu"), (["--density", "nan"], "--density nan"),
              (["--max-seconds", "-1"], "--max-seconds -1"), (["--tolerance", "inf"], "--tolerance inf"),
              (["--stretch-stiffness", "0"], "--stretch-stiffness 0"),
              (["--max-iterations", "-2"], "--max-iterations -2")],
    "grade": [(["--fix", "0"], "--fix 0: must be > 0"), (["--fix", "nan"], "--fix nan"), (["--fix", "-1"], "--fix -1"),
              (["--cur", "inf"], "--cur inf"), (["--time-budget", "-1"], "--time-budget -1"),
              (["--time-budget", "nan"], "--time-budget nan"), (["--edge-length", "0.05"], "SEAMFIT_MAX_MESH_VERTICES"),
              (["--edge-length", "1e-4"], "mesh vertices"), (["--sdf-spacing", "inf"], "--sdf-spacing inf"),
              (["-S", "0"], "--inner-iterations 0"), (["--checkpoint-every", "0"], "--checkpoint-every 0"),
              (["--adjoint-forcing", "nan"], "--adjoint-forcing nan")],
    "sdf": [(["--spacing", "nan"], "--spacing nan"), (["--padding", "-1"], "--padding -1")],
    "validate": [(["--seam-tolerance", "nan"], "--seam-tolerance")],
}


def option_argv(command, out, extra):
    base = {"mesh": ["mesh", PENCIL, "--out", out], "drape": ["drape", PENCIL, B0, "--out", out],
            "grade": ["grade", PENCIL, "--base-body", B0, "--target-body", B1, "--out", out, "--no-picture"],
            "sdf": ["sdf", B0, "--out", out.with_suffix(".npz")], "validate": ["validate", PENCIL]}[command]
    return base + extra


@pytest.mark.parametrize("command,extra,name", [(c, e, n) for c, cases in BAD_OPTIONS.items() for e, n in cases],
                         ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_bad_option(tmp_path, capsys, monkeypatch, command, extra, name):
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "out"
    code, _, err, secs = run(capsys, *option_argv(command, out, extra))
    assert_refused(code, err, secs, command, name, validate_exit=(2,))
    assert not out.exists() and not out.with_suffix(".npz").exists()


# ----------------------------------------------------------------------------- output paths

def test_a_full_disk_is_one_line_naming_the_output(tmp_path, capsys, monkeypatch):
    import seamfit.fileio as fileio

    def full(path, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    monkeypatch.setattr(fileio, "atomic_write_bytes", full)
    out = tmp_path / "out"
    code, _, err, _ = run(capsys, "mesh", PENCIL, "--out", out, "--edge-length", "5")
    assert code == 2 and "Traceback" not in err and err.count("\n") == 1, err
    assert f"seamfit mesh: error: {out}: could not write the results" in err and "No space left" in err
    assert not out.exists() and not list(tmp_path.glob(".out*"))


def test_an_unexpected_exception_is_one_line_and_the_traceback_on_request(tmp_path, capsys, monkeypatch):
    import seamfit.mesh as mesh_pkg

    def broken(*a, **kw):
        raise RuntimeError("something\nunforeseen")
    monkeypatch.setattr(mesh_pkg, "build_sewn_mesh", broken)
    argv = ["mesh", PENCIL, "--out", tmp_path / "out", "--edge-length", "5"]
    code, _, err, _ = run(capsys, *argv)
    assert code == 3 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "seamfit mesh: internal error: RuntimeError: something unforeseen" in err
    monkeypatch.setenv("SEAMFIT_TRACEBACK", "1")
    with pytest.raises(RuntimeError):
        cli.main([str(a) for a in argv])


def test_several_pattern_errors_are_one_line_each(tmp_path, capsys):
    d = pencil()
    d["panels"][0]["edges"][0]["kind"] = "spline"
    d["panels"][1]["edges"][0]["start"] = 10**6
    pattern = write(tmp_path, "two.json", d)
    code, _, err, secs = run(capsys, "mesh", pattern, "--out", tmp_path / "out")
    assert_refused(code, err, secs, "mesh", "unknown curve kind", "outside the outline")
    assert err.count("\n") == 2 and all(str(pattern) in line for line in err.splitlines())


# ----------------------------------------------------------------------------- smaller cases

def test_a_stray_far_vertex_does_not_stretch_the_field(tmp_path, capsys, monkeypatch):
    """An unreferenced vertex at 1e308 once gave an all-+inf SDF, exit 0, and Infinity in the report."""
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    body = write(tmp_path, "stray.obj", B0.read_text() + "v 1e308 1e308 1e308\n")
    code, out, err, _ = run(capsys, "validate", body)
    assert code == 0 and "1 vertices are used by no face (e.g. vertex 13380); they are ignored" in out
    code, out, err, _ = run(capsys, "sdf", body, "--out", tmp_path / "s.npz", "--spacing", "0.02")
    assert code == 0, err

    def no_constants(name):
        raise AssertionError(f"{name} in the report")
    report = json.loads((tmp_path / "s.json").read_text(), parse_constant=no_constants)
    assert -0.2 < report["min_phi"] < 0 < report["max_phi"] < 1
    code, _, err, _ = run(capsys, "sdf", B0, "--out", tmp_path / "clean.npz", "--spacing", "0.02")
    assert code == 0, err
    clean = json.loads((tmp_path / "clean.json").read_text())
    assert report["dims"] == clean["dims"] and report["origin"] == clean["origin"]   # the body's box
    assert report["min_phi"] == clean["min_phi"] and report["max_phi"] == clean["max_phi"]


def test_sdfs_are_cached_under_sdf_with_a_cache_dir(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    from seamfit.body import sdf as sdf_mod
    sdf_mod.clear_memory_cache()
    code, _, err, _ = run(capsys, "sdf", B0, "--out", tmp_path / "s.npz", "--spacing", "0.03")
    assert code == 0, err
    assert [p.parent.name for p in (tmp_path / "cache").rglob("*.npz")] == ["sdf"]


def test_validate_summarises_a_body(capsys):
    code, out, _, _ = run(capsys, "validate", B0)
    assert code == 0 and "BodyReport(" not in out
    assert ("  vertices: 13380, faces: 26756, height: 1.650 m, volume: 52.3 litres, components: 1, "
            "watertight: yes, inverted: no") in out


def test_truth_is_read_before_the_grading(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    truth = write(tmp_path, "truth.json", {"format": "sewpat-1", "panels": "none"})
    code, _, err, secs = run(capsys, "grade", PENCIL, "--base-body", B0, "--target-body", B1, "--truth", truth,
                             "--out", tmp_path / "out", *QUICK)
    assert_refused(code, err, secs, "grade", truth, "panels must be a list")
    assert not (tmp_path / "cache").exists()                # no SDF, no base drape
    other = sorted((SAMPLES / "patterns/fs_bodice").glob("*/pattern.json"))[0]   # no panel in common
    code, _, err, secs = run(capsys, "grade", PENCIL, "--base-body", B0, "--target-body", B1, "--truth", other,
                             "--out", tmp_path / "out", *QUICK)
    assert_refused(code, err, secs, "grade", other, "no panel name in common")
    assert not (tmp_path / "cache").exists()


def test_a_target_body_with_inverted_normals_is_graded(tmp_path, capsys, monkeypatch):
    """validate repairs it (a warning); grade once refused it as another topology."""
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    lines = [line if not line.startswith("f ") else "f " + " ".join(reversed(line.split()[1:]))
             for line in B1.read_text().splitlines()]
    inverted = write(tmp_path, "inverted.obj", "\n".join(lines) + "\n")
    code, out, _, _ = run(capsys, "validate", inverted)
    assert code == 0 and "inside-out" in out
    code, _, err, _ = run(capsys, "grade", PENCIL, "--base-body", B0, "--target-body", inverted,
                          "--out", tmp_path / "out", "--max-iterations", "1", *QUICK)
    assert code == 0, err
    assert "inside-out" in err and "topology" not in err
    assert (tmp_path / "out" / "pattern.json").is_file()


def test_another_topology_that_cannot_be_registered_is_refused_before_the_base_drape(tmp_path, capsys,
                                                                                     monkeypatch):
    """A target of another mesh is registered onto the base body's (tests/body/test_register.py);
    one that cannot be (here: a hole) is refused by the registration's checks, at once."""
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    lines = B1.read_text().splitlines()
    first_face = next(k for k, line in enumerate(lines) if line.startswith("f "))
    del lines[first_face]
    other = write(tmp_path, "other.obj", "\n".join(lines) + "\n")
    code, _, err, secs = run(capsys, "grade", PENCIL, "--base-body", B0, "--target-body", other,
                             "--out", tmp_path / "out", *QUICK)
    assert_refused(code, err, secs, "grade", other, "not closed", "3 boundary edges")
    assert not (tmp_path / "cache").exists()


def test_a_nul_in_a_name_still_draws_a_well_formed_svg(tmp_path, capsys):
    import xml.etree.ElementTree as ET
    pattern = _edit(_nul_name, "nul_name.json")(tmp_path)
    code, out, err, _ = run(capsys, "validate", pattern, "--svg", tmp_path / "p.svg")
    assert code == 1 and "printable characters" in err
    root = ET.parse(tmp_path / "p.svg").getroot()           # once: not well-formed (a raw NUL)
    assert any(e.get("data-panel") == "skirt\ufffdback" for e in root.iter())


@pytest.mark.parametrize("case", ["100k-deep nesting", "a device (/dev/zero)", "5000-digit integer"])
def test_bad_measurement_files(tmp_path, capsys, case):
    make, names = BAD_PATTERNS[case]
    path = make(tmp_path)
    code, _, err, secs = run(capsys, "body", "--measurements", path, "--out", tmp_path / "b.obj")
    assert_refused(code, err, secs, "body", path, names[0])
    assert not (tmp_path / "b.obj").exists()


def test_the_mesh_limit_holds_for_every_caller_of_the_mesher():
    from seamfit.errors import LimitError
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    t0 = time.perf_counter()
    with pytest.raises(LimitError, match="SEAMFIT_MAX_MESH_VERTICES"):
        build_sewn_mesh(load_pattern(PENCIL), 0.05)
    assert time.perf_counter() - t0 < FAST_S


def test_many_pattern_errors_are_capped_with_a_count(tmp_path, capsys):
    d = pencil()
    for e in d["panels"][0]["edges"]:
        e["kind"] = "spline"
    pattern = write(tmp_path, "many.json", d)
    n = len(d["panels"][0]["edges"])
    code, _, err, secs = run(capsys, "mesh", pattern, "--out", tmp_path / "out")
    assert_refused(code, err, secs, "mesh", "unknown curve kind")
    lines = err.splitlines()
    assert len(lines) == cli.MAX_ERROR_LINES + 1
    assert lines[-1] == (f"seamfit mesh: error: ... and {n - cli.MAX_ERROR_LINES} more "
                         "(seamfit validate lists them all)")


def test_batch_without_ray_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    # an install without ray (e.g. --no-deps) gets a one-line answer
    monkeypatch.setitem(sys.modules, "ray", None)      # `import ray` raises ImportError
    manifest = write(tmp_path, "m.json", {"defaults": {"pattern": str(PENCIL), "base_body": str(B0)},
                                          "jobs": [{"id": "size10", "target_body": str(B1)}]})
    code, _, err, secs = run(capsys, "batch", manifest, "--out", tmp_path / "out")
    assert_refused(code, err, secs, "batch", "seamfit[batch]", "not installed")
    assert not (tmp_path / "out").exists()
