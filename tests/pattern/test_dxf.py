"""DXF-AAMA and DXF-ASTM: reading Valentina's exports (shared/data/dxf), round trips in both
flavours, notches, grain lines and piece texts, seam allowances, the seams sidecar and the
``seamfit convert`` / ``seamfit validate`` commands on DXF, and one-line errors on bad files."""
from __future__ import annotations

import copy
import json
from pathlib import Path

import ezdxf
import numpy as np
import pytest

from seamfit.errors import PatternError
from seamfit.pattern import load_pattern, validate_pattern
from seamfit.pattern.allowance import cut_line
from seamfit.pattern.dxf import FIT_TOL_CM, read_dxf_file, write_dxf
from seamfit.pattern.io import read_pattern_file
from seamfit.pattern.refit import project_onto_curve
from seamfit.pattern.seams import apply_sidecar, propose_stitches, sidecar_dict, write_sidecar
from common import REPO, SHARED_DATA, run_cli
from outlines import polyline_distance

# the shared data sits beside the clone (../shared), as in CI
DXF_DIR = SHARED_DATA / "dxf"
PENCIL = REPO / "sample_files/patterns/gc_pencil_skirt/size06/pattern.json"
FILES = sorted(p.name for p in DXF_DIR.glob("*.dxf"))


def test_the_shared_dxf_samples_are_there():
    assert len(FILES) == 16, f"expected Valentina's 8 AAMA and 8 ASTM exports in {DXF_DIR}"


@pytest.fixture(scope="module")
def read_all():
    return {name: read_dxf_file(DXF_DIR / name) for name in FILES}


def _file_polylines(path: Path, layers: set[str]) -> dict[str, list[np.ndarray]]:
    """Closed polylines (cm) per layer, straight from the file with ezdxf, for reference."""
    doc, _ = ezdxf.recover.readfile(str(path))
    out: dict[str, list[np.ndarray]] = {}
    for blk in doc.blocks:
        for e in blk:
            if e.dxftype() == "LWPOLYLINE" and e.dxf.layer in layers:
                out.setdefault(e.dxf.layer, []).append(np.array(e.get_points("xy"), dtype=float) / 10.0)
    return out


@pytest.mark.parametrize("name", FILES)
def test_reads_every_piece_with_its_seam_line_from_the_file(read_all, name):
    res = read_all[name]
    p = res.pattern
    flavor = name.split(".")[-2]
    assert res.flavor == flavor and res.units == "mm"
    doc, _ = ezdxf.recover.readfile(str(DXF_DIR / name))
    n_inserts = sum(1 for e in doc.modelspace() if e.dxftype() == "INSERT")
    assert len(p.panels) == n_inserts and len({pn.name for pn in p.panels}) == n_inserts
    assert not validate_pattern(p).errors
    # every vertex of every seam line in the file (ASTM: layer 14, else the boundary) is a
    # vertex of a panel outline, up to the reader moving far pieces to the origin
    ref = _file_polylines(DXF_DIR / name, {"1", "8", "14"})
    for pn in p.panels:
        shift = np.array(pn.extra["dxf"].get("insert_cm", [0.0, 0.0]))
        o = pn.outline_cm + shift
        on_file = [poly for layer in ("14", "8", "1") for poly in ref.get(layer, [])
                   if len(poly) and np.abs(poly[:, None, :] - o[None, :, :]).sum(axis=2).min(axis=1).max() < 1e-6]
        assert on_file, f"{pn.name}: outline is no polyline of the file"


@pytest.mark.parametrize("name", FILES)
def test_fitted_edges_pass_within_the_tolerance_of_every_file_vertex(read_all, name):
    for pn in read_all[name].pattern.panels:
        n = pn.n_vertices
        assert pn.edges and pn.edges[0].start == 0
        for e in pn.edges:
            assert e.kind in ("line", "cubic")
            idx = (e.start + np.arange((e.end - e.start) % n + 1)) % n
            pts = pn.outline_cm[idx]
            # points added on long segments lie on the file's straight segments; the file's
            # own vertices are those the curve was fitted to
            on, _ = project_onto_curve(e, pts)
            d = np.linalg.norm(on - pts, axis=1)
            assert d[[0, -1]].max() < 1e-9
        # outline samples at most 1 cm apart, or as the file had them up to 1.5 cm
        seg = np.linalg.norm(np.roll(pn.outline_cm, -1, axis=0) - pn.outline_cm, axis=1)
        assert seg.max() <= 1.5 + 1e-9


def test_fit_tolerance_on_the_file_vertices(read_all):
    worst = 0.0
    for res in read_all.values():
        src = _file_polylines(DXF_DIR / Path(res.pattern.source_file).name, {"1", "14", "8"})
        verts = np.vstack([poly for polys in src.values() for poly in polys])
        for pn in res.pattern.panels:
            o = pn.outline_cm
            n = len(o)
            for e in pn.edges:
                idx = (e.start + np.arange((e.end - e.start) % n + 1)) % n
                pts = o[idx]
                # the file's vertices among them: those not on the straight line of their neighbours
                on, _ = project_onto_curve(e, pts)
                d = np.linalg.norm(on - pts, axis=1)
                shifted = pts + np.array(pn.extra["dxf"].get("insert_cm", [0, 0]))
                file_v = np.array([np.abs(verts - q).sum(axis=1).min() < 1e-6 for q in shifted])
                worst = max(worst, float(d[file_v].max()))
    assert worst <= FIT_TOL_CM + 1e-9


@pytest.mark.parametrize("flavor", ["aama", "astm"])
def test_round_trip_keeps_points_edges_names_and_audits_clean(read_all, tmp_path, flavor):
    worst = 0.0
    for name, res in read_all.items():
        p = res.pattern
        out = tmp_path / f"rt.{flavor}.dxf"
        write_dxf(p, out, flavor=flavor)
        doc = ezdxf.readfile(out)
        auditor = doc.audit()
        assert not auditor.has_errors and not auditor.has_fixes, name
        back = read_dxf_file(out)
        assert back.flavor == flavor
        q = back.pattern
        assert [x.name for x in q.panels] == [x.name for x in p.panels], name
        for a, b in zip(p.panels, q.panels):
            assert a.outline_cm.shape == b.outline_cm.shape, (name, a.name)
            worst = max(worst, float(np.abs(a.outline_cm - b.outline_cm).max()))
            assert [(e.start, e.end, e.kind) for e in a.edges] == [(e.start, e.end, e.kind) for e in b.edges]
            assert a.corners == b.corners
            for key in ("size", "category", "quantity", "material"):
                assert a.extra.get(key) == b.extra.get(key)
            ca, cb = a.extra["dxf"].get("cut_line_cm"), b.extra["dxf"].get("cut_line_cm")
            assert (ca is None) == (cb is None)
            if ca is not None:
                worst = max(worst, float(np.abs(np.array(ca) - np.array(cb)).max()))
            assert a.extra["dxf"].get("insert_cm") == pytest.approx(b.extra["dxf"].get("insert_cm"))
    assert worst * 10.0 < 0.1            # mm; in fact ~1e-10 (the file keeps 16 digits)


def _with_marks(p):
    """The pattern with three notches of different kinds, a grain line, a drill hole and a
    size on every panel."""
    p = copy.deepcopy(p)
    for k, pn in enumerate(p.panels):
        n = pn.n_vertices
        verts = sorted({n // 5, n // 2, (4 * n) // 5} - set(pn.corners))
        pn.extra["notches"] = [{"vertex": v, "type": t, "depth_cm": d}
                               for v, t, d in zip(verts, ("slit", "T", "U"), (0.6, 0.8, 0.5))]
        lo, hi = pn.outline_cm.min(axis=0), pn.outline_cm.max(axis=0)
        mid = 0.5 * (lo + hi)
        pn.extra["grain_line_cm"] = [[mid[0], lo[1] + 0.2 * (hi[1] - lo[1])], [mid[0], hi[1] - 0.2 * (hi[1] - lo[1])]]
        pn.extra["drill_holes_cm"] = [[float(mid[0]), float(mid[1])]]
        pn.extra["size"] = "38"
    return p


@pytest.mark.parametrize("flavor", ["aama", "astm"])
def test_notches_grain_drill_holes_and_texts_survive_a_round_trip(read_all, tmp_path, flavor):
    for name, res in read_all.items():
        p = _with_marks(res.pattern)
        out = tmp_path / f"marks.{flavor}.dxf"
        write_dxf(p, out, flavor=flavor)
        q = read_dxf_file(out).pattern
        for a, b in zip(p.panels, q.panels):
            assert a.name == b.name
            got = [(x["vertex"], x["type"], round(x["depth_cm"], 6)) for x in b.extra["notches"]]
            assert got == [(x["vertex"], x["type"], x["depth_cm"]) for x in a.extra["notches"]], (name, a.name)
            assert [b.landmarks[f"notch_{j}"] for j in range(len(a.extra["notches"]))] == [x["vertex"] for x in a.extra["notches"]]
            np.testing.assert_allclose(b.extra["grain_line_cm"], a.extra["grain_line_cm"], atol=1e-9)
            np.testing.assert_allclose(b.extra["drill_holes_cm"], a.extra["drill_holes_cm"], atol=1e-9)
            assert b.extra["size"] == "38"


def _drawing(tmp_path, name="piece.dxf", *, units=1, width=10.0, notch=True, closed=True, texts=True,
             grain=True, notch_off=0.0):
    """A one-piece AAMA drawing made with ezdxf: a width x 8 rectangle (drawing units)."""
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = units
    blk = doc.blocks.new("FRONT")
    pts = [(0, 0), (width, 0), (width, 8), (0, 8)]
    blk.add_lwpolyline(pts, close=closed, dxfattribs={"layer": "1"})
    if notch:                                   # a slit notch in the middle of the bottom edge
        blk.add_line((width / 2, -notch_off), (width / 2, 0.25 - notch_off), dxfattribs={"layer": "4"})
    if grain:
        blk.add_line((2, 1), (2, 7), dxfattribs={"layer": "7"})
    blk.add_point((width / 2, 4), dxfattribs={"layer": "13"})
    blk.add_lwpolyline([(3, 2), (4, 5), (5, 2)], dxfattribs={"layer": "8"})
    if texts:
        for j, t in enumerate(("Piece Name: Front", "Size: 12", "Category: Shell", "Quantity: 2", "keep me")):
            blk.add_text(t, height=0.3, dxfattribs={"layer": "1", "insert": (1, 6 - 0.5 * j)})
    doc.modelspace().add_blockref("FRONT", (0, 0))
    doc.modelspace().add_text("Style Name: Test Skirt", dxfattribs={"layer": "1"})
    path = tmp_path / name
    doc.saveas(path)
    return path


def test_reads_an_inch_drawing_with_notch_grain_drill_hole_internal_line_and_texts(tmp_path):
    res = read_dxf_file(_drawing(tmp_path))
    assert res.units == "in" and res.flavor == "aama"
    p = res.pattern
    assert p.extra["style_name"] == "Test Skirt"
    (pn,) = p.panels
    assert pn.name == "Front" and pn.extra["size"] == "12" and pn.extra["category"] == "Shell"
    assert pn.extra["quantity"] == "2"
    assert [t["text"] for t in pn.extra["dxf"]["texts"]] == ["keep me"]
    o = pn.outline_cm
    assert np.ptp(o[:, 0]) == pytest.approx(25.4) and np.ptp(o[:, 1]) == pytest.approx(8 * 2.54)
    assert abs(pn.signed_area_cm2()) == pytest.approx(10 * 8 * 2.54 ** 2)
    assert sorted(e.kind for e in pn.edges) == ["line"] * 4 and len(pn.corners) == 4
    (notch,) = pn.extra["notches"]
    assert o[notch["vertex"]] == pytest.approx([5 * 2.54, 0.0])
    assert notch["depth_cm"] == pytest.approx(0.25 * 2.54) and notch["angle_deg"] == pytest.approx(90.0)
    np.testing.assert_allclose(pn.extra["grain_line_cm"], [[2 * 2.54, 2.54], [2 * 2.54, 7 * 2.54]])
    np.testing.assert_allclose(pn.extra["drill_holes_cm"], [[5 * 2.54, 4 * 2.54]])
    (line,) = pn.extra["internal_lines"]
    assert line["closed"] is False
    np.testing.assert_allclose(line["points_cm"], np.array([(3, 2), (4, 5), (5, 2)]) * 2.54)


def test_seam_allowance_on_export_mitred_and_squared(tmp_path):
    p = read_dxf_file(_drawing(tmp_path, units=4, width=300.0, texts=False)).pattern   # mm: 30 x 0.8 cm
    (pn,) = p.panels
    assert np.ptp(pn.outline_cm[:, 0]) == pytest.approx(30.0)
    for corners in ("mitre", "square"):
        out = tmp_path / f"sa_{corners}.astm.dxf"
        write_dxf(p, out, flavor="astm", seam_allowance_cm=1.0, corners=corners)
        assert not ezdxf.readfile(out).audit().has_errors
        q = read_dxf_file(out).pattern.panels[0]
        np.testing.assert_allclose(q.outline_cm, pn.outline_cm, atol=1e-9)   # the sew line
        cut = np.array(q.extra["dxf"]["cut_line_cm"])
        assert all(e.extra["seam_allowance_cm"] == pytest.approx(1.0) for e in q.edges)
        d = polyline_distance(cut, pn.outline_cm)
        lo, hi = pn.outline_cm.min(axis=0), pn.outline_cm.max(axis=0)
        # the rectangle grown by 1 cm; at 90 deg squaring meets at the mitre point too
        assert d.min() == pytest.approx(1.0) and d.max() == pytest.approx(np.sqrt(2.0))
        assert cut.min(axis=0) == pytest.approx(lo - 1) and cut.max(axis=0) == pytest.approx(hi + 1)
        # the notch is cut into the cutting line and still sits on its seam-line vertex
        (notch,) = q.extra["notches"]
        assert q.outline_cm[notch["vertex"]] == pytest.approx(pn.outline_cm[pn.extra["notches"][0]["vertex"]])


def test_notches_cut_into_the_cut_line_come_back_on_their_vertices(tmp_path):
    # A notch written into the cutting line runs, carried on, through its seam-line vertex
    # exactly; rounding can put that crossing a hair past both segments meeting there, and
    # the ray then went on to the far side of the piece and added an outline point there.
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 5
    doc.blocks.new("P").add_lwpolyline([(0.3, 0.1), (40.7, 0.18387), (40.2, 20.3), (0.1, 19.9)], close=True,
                                       dxfattribs={"layer": "1"})
    doc.modelspace().add_blockref("P", (0, 0))
    doc.saveas(tmp_path / "p.dxf")
    p = read_dxf_file(tmp_path / "p.dxf").pattern
    (pn,) = p.panels
    pn.extra["notches"] = [{"vertex": v, "type": "slit", "depth_cm": 0.6}
                           for v in range(len(pn.outline_cm)) if v not in pn.corners]
    assert len(pn.extra["notches"]) > 100
    out = tmp_path / "p.aama.dxf"
    write_dxf(p, out, seam_allowance_cm=1.0)
    q = read_dxf_file(out).pattern.panels[0]
    np.testing.assert_allclose(q.outline_cm, pn.outline_cm, atol=1e-9)
    assert [x["vertex"] for x in q.extra["notches"]] == [x["vertex"] for x in pn.extra["notches"]]


def test_square_corners_cut_a_sharp_corner_short(tmp_path):
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 5                         # cm: a right triangle, two 45 deg corners
    doc.blocks.new("T").add_lwpolyline([(0, 0), (20, 0), (0, 20)], close=True, dxfattribs={"layer": "1"})
    doc.modelspace().add_blockref("T", (0, 0))
    doc.saveas(tmp_path / "t.dxf")
    pn = read_dxf_file(tmp_path / "t.dxf").pattern.panels[0]
    mitre, square = cut_line(pn, 1.5, "mitre"), cut_line(pn, 1.5, "square")
    dm, ds = polyline_distance(mitre, pn.outline_cm), polyline_distance(square, pn.outline_cm)
    for d in (dm, ds):
        assert d.min() == pytest.approx(1.5)            # never inside the allowance
    assert dm.max() == pytest.approx(1.5 / np.sin(np.radians(22.5)))    # the mitre's point
    assert ds.max() < 0.75 * dm.max()                   # squared: cut short


def test_kept_cut_line_is_written_back_until_the_seam_line_moves(read_all, tmp_path):
    res = read_all["modell_2.aama.dxf"]
    p = copy.deepcopy(res.pattern)
    pn = p.panels[0]
    cut0 = np.array(pn.extra["dxf"]["cut_line_cm"])
    widths = [e.extra["seam_allowance_cm"] for e in pn.edges]
    assert min(widths) > 0.5 and max(widths) < 2.0        # Valentina's 1 cm allowance
    pn.outline_cm = pn.outline_cm * 1.02                  # as grading would move it
    out = tmp_path / "moved.aama.dxf"
    write_dxf(p, out)
    q = read_dxf_file(out).pattern.panels[0]
    cut1 = np.array(q.extra["dxf"]["cut_line_cm"])
    assert cut1.shape != cut0.shape or np.abs(cut1 - cut0).max() > 0.1     # rebuilt, not the stale one
    # rebuilt from the measured per-edge allowances
    for e0, e1 in zip(pn.edges, q.edges):
        assert e1.extra["seam_allowance_cm"] == pytest.approx(e0.extra["seam_allowance_cm"], abs=0.05)


def test_proposed_stitches_pair_equal_runs_and_the_sidecar_round_trips(tmp_path):
    p = load_pattern(PENCIL)
    props = propose_stitches(p)
    assert props and all(not s["confirmed"] for s in props)
    for s in props:
        assert abs(s["length_a_cm"] - s["length_b_cm"]) <= max(0.3, 0.01 * max(s["length_a_cm"], s["length_b_cm"]))
    # every run is used at most once
    used = [(s[k]["panel"], tuple(s[k]["from"])) for s in props for k in "ab"]
    assert len(used) == len(set(used))
    # a sewpat pattern's own stitches written to a sidecar come back as the same ranges
    side = tmp_path / "skirt.seams.json"
    write_sidecar(side, sidecar_dict(p, props))
    q = copy.deepcopy(p)
    q.stitches = []
    assert apply_sidecar(q, side) == len(p.stitches)
    assert [(s.a.panel, s.a.range, s.b.panel, s.b.range, s.orientation, s.gathered) for s in q.stitches] == \
           [(s.a.panel, s.a.range, s.b.panel, s.b.range, s.orientation, s.gathered) for s in p.stitches]
    # confirming a proposal adds it
    d = json.loads(side.read_text())
    d["stitches"][len(p.stitches)]["confirmed"] = True
    side.write_text(json.dumps(d))
    assert apply_sidecar(q, side) == len(p.stitches) + 1


def test_proposals_match_notched_sides(tmp_path):
    # two rectangles of equal height: their long sides all match by length; the notches,
    # 20 cm up on A's right side and on B's left side, say which two are sewn
    def rect(name, x):
        doc_pts = np.array([(x, 0), (x + 20, 0), (x + 20, 50), (x, 50)], dtype=float)
        return name, doc_pts
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 5                         # cm
    for name, pts in (rect("A", 0), rect("B", 40)):
        blk = doc.blocks.new(name)
        blk.add_lwpolyline(pts.tolist(), close=True, dxfattribs={"layer": "1"})
        doc.modelspace().add_blockref(name, (0, 0))
    doc.blocks.get("A").add_line((20, 20), (19.5, 20), dxfattribs={"layer": "4"})    # A's right side, 20 up
    doc.blocks.get("B").add_line((40, 20), (40.5, 20), dxfattribs={"layer": "4"})    # B's left side, 20 up
    path = tmp_path / "two.dxf"
    doc.saveas(path)
    p = read_dxf_file(path).pattern
    best = propose_stitches(p)[0]
    assert {best["a"]["panel"], best["b"]["panel"]} == {"A", "B"}
    sides = {best["a"]["panel"]: best["a"], best["b"]["panel"]: best["b"]}
    assert {sides["A"]["from"][0], sides["A"]["to"][0]} == {20.0} and {sides["B"]["from"][0], sides["B"]["to"][0]} == {40.0}
    assert "line up" in best["why"]


# ----------------------------------------------------------------------------- CLI

def test_convert_sewpat_to_dxf_and_back_keeps_stitches_and_placements(tmp_path, capsys):
    out = tmp_path / "skirt.astm.dxf"
    code, o, err = run_cli(capsys, "convert", PENCIL, "--out", out)
    assert code == 0, err
    assert out.is_file() and (tmp_path / "skirt.seams.json").is_file()
    assert "DXF-ASTM" in o
    back = tmp_path / "back.json"
    code, o, err = run_cli(capsys, "convert", out, "--out", back)
    assert code == 0, err
    p, q = load_pattern(PENCIL), load_pattern(back)
    assert [x.name for x in q.panels] == [x.name for x in p.panels]
    for a, b in zip(p.panels, q.panels):
        np.testing.assert_allclose(b.outline_cm, a.outline_cm, atol=1e-9)
        np.testing.assert_allclose(b.placement.rotation, a.placement.rotation, atol=1e-12)
        np.testing.assert_allclose(b.placement.translation_m, a.placement.translation_m, atol=1e-12)
        assert b.placement.side == a.placement.side and b.placement.extra == a.placement.extra
    assert [(s.a.panel, s.a.range, s.b.panel, s.b.range, s.gathered) for s in q.stitches] == \
           [(s.a.panel, s.a.range, s.b.panel, s.b.range, s.gathered) for s in p.stitches]
    assert q.garment_type == p.garment_type
    # validate reads the DXF with its sidecar
    code, o, err = run_cli(capsys, "validate", out)
    assert code == 0 and "DXF-ASTM" in o and "stitches: 20" in o and o.rstrip().endswith("OK")
    # an existing output is replaced only with --force; an SVG is written by extension
    code, _, err = run_cli(capsys, "convert", PENCIL, "--out", out)
    assert code == 2 and "--force" in err and len(err.strip().splitlines()) == 1
    code, _, err = run_cli(capsys, "convert", out, "--out", tmp_path / "skirt.svg")
    assert code == 0 and (tmp_path / "skirt.svg").read_text().lstrip().startswith("<?xml")


def test_convert_flavor_option_and_propose_seams(tmp_path, capsys):
    src = DXF_DIR / "Keiko_skirt.aama.dxf"
    before = src.read_bytes()
    out = tmp_path / "keiko.dxf"
    seams = tmp_path / "keiko.seams.json"
    code, o, err = run_cli(capsys, "convert", src, "--out", out, "--dxf-flavor", "astm", "--propose-seams", seams)
    assert code == 0, err
    assert "DXF-ASTM" in o and read_dxf_file(out).flavor == "astm"
    d = json.loads(seams.read_text())
    assert d["format"] == "seamfit-seams-1" and d["stitches"] and not any(s["confirmed"] for s in d["stitches"])
    for s in d["stitches"]:
        s["confirmed"] = True
    seams.write_text(json.dumps(d))
    code, o, err = run_cli(capsys, "convert", out, "--seams", seams, "--out", tmp_path / "keiko.json")
    assert code == 0, err
    assert len(load_pattern(tmp_path / "keiko.json").stitches) == len(d["stitches"])
    assert src.read_bytes() == before


def test_convert_refuses_unknown_output_and_its_own_input(tmp_path, capsys):
    code, _, err = run_cli(capsys, "convert", PENCIL, "--out", tmp_path / "x.pdf")
    assert code == 2 and "x.pdf" in err and ".pdf" in err
    src = tmp_path / "p.dxf"
    write_dxf(load_pattern(PENCIL), src)
    code, _, err = run_cli(capsys, "convert", src, "--out", src, "--force")
    assert code == 2 and "would replace the input" in err


# ----------------------------------------------------------------------------- bad files

def _one_line_error(capsys, path, *names, extra=(), at_fault=None):
    code, out, err = run_cli(capsys, "validate", path, *extra)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "Traceback" not in err and str(at_fault or path) in lines[0]
    for name in names:
        assert name in lines[0], lines[0]
    with pytest.raises(PatternError):
        read_pattern_file(path, dxf_units=extra[1] if extra else None)
    return lines[0]


def test_not_a_dxf(tmp_path, capsys):
    path = tmp_path / "junk.dxf"
    path.write_text("hello, this is no drawing\n")
    _one_line_error(capsys, path)
    empty = tmp_path / "empty.dxf"
    empty.write_text("")
    assert "empty file" in _one_line_error(capsys, empty)


def test_open_boundary_names_the_piece(tmp_path, capsys):
    msg = _one_line_error(capsys, _drawing(tmp_path, closed=False), "'Front'", "not closed")
    assert "layer 1" in msg


def test_implausible_units_name_the_piece_and_the_units(tmp_path, capsys):
    path = _drawing(tmp_path, units=6, width=30.0)          # metres: a 30 m piece
    msg = _one_line_error(capsys, path, "'Front'", "units m", "$INSUNITS 6", "--dxf-units")
    assert "not a plausible pattern piece" in msg
    # told the real units, it reads
    assert read_pattern_file(path, dxf_units="cm")[0].panels[0].name == "Front"


def test_piece_without_boundary_and_notch_off_the_outline(tmp_path, capsys):
    doc = ezdxf.new("R2000")
    blk = doc.blocks.new("SLEEVE")
    blk.add_line((0, 0), (100, 0), dxfattribs={"layer": "7"})
    doc.modelspace().add_blockref("SLEEVE", (0, 0))
    path = tmp_path / "noboundary.dxf"
    doc.saveas(path)
    _one_line_error(capsys, path, "'SLEEVE'", "no boundary")
    _one_line_error(capsys, _drawing(tmp_path, "farnotch.dxf", notch_off=3.0), "'Front'", "notch")


def test_bad_sidecar_names_the_file_and_the_stitch(tmp_path, capsys):
    src = tmp_path / "piece.dxf"
    _drawing(tmp_path, "piece.dxf")
    side = tmp_path / "piece.seams.json"
    side.write_text(json.dumps({"format": "seamfit-seams-1", "stitches": [
        {"a": {"panel": "Front", "from": [0, 0], "to": [25.4, 0]},
         "b": {"panel": "Back", "from": [0, 0], "to": [1, 0]}, "confirmed": True}]}))
    _one_line_error(capsys, src, "stitch 0", "'Back'", at_fault=side)
    side.write_text(json.dumps({"format": "seamfit-seams-1", "stitches": [
        {"a": {"panel": "Front", "from": [0, 0], "to": [25.4, 0]},
         "b": {"panel": "Front", "from": [3, 3], "to": [25.4, 20.32]}, "confirmed": True}]}))
    _one_line_error(capsys, src, "stitch 0 side b 'from'", "no outline vertex", at_fault=side)
    side.write_text("{")
    _one_line_error(capsys, src, "invalid JSON", at_fault=side)


def test_placement_anchors_survive_the_sidecar(tmp_path, capsys):
    # FreeSewing hint placements name the landmark the dressing anchors at the waist; DXF keeps
    # no landmark names, so the sidecar gives its point too and reading puts the landmark back
    src = REPO / "sample_files/patterns/fs_bodice/size06/pattern.json"
    dxf, back = tmp_path / "bodice.astm.dxf", tmp_path / "back.json"
    assert run_cli(capsys, "convert", src, "--out", dxf)[0] == 0
    assert run_cli(capsys, "convert", dxf, "--out", back)[0] == 0
    p, q = load_pattern(src), load_pattern(back)
    for a, b in zip(p.panels, q.panels):
        assert b.placement.extra == a.placement.extra and b.placement.side == a.placement.side
        mark = a.placement.extra["anchor_landmark"]
        np.testing.assert_allclose(b.outline_cm[b.landmarks[mark]], a.outline_cm[a.landmarks[mark]], atol=1e-6)
    side = json.loads((tmp_path / "bodice.seams.json").read_text())
    first = next(iter(side["placements"]))
    del side["placements"][first]["anchor_landmark_at_cm"]
    write_sidecar(tmp_path / "bodice.seams.json", side)
    code, _, err = run_cli(capsys, "validate", dxf)
    assert code == 2 and f"placement of {first!r}: anchor_landmark" in err and "is not a landmark" in err
    assert len(err.strip().splitlines()) == 1


def test_grading_a_dxf_without_stitches_or_placements_stops_before_any_work(tmp_path, capsys):
    src = DXF_DIR / "Keiko_skirt.astm.dxf"
    dxf = tmp_path / "keiko.astm.dxf"
    dxf.write_bytes(src.read_bytes())
    bodies = DXF_DIR.parent / "bodies"
    argv = ["grade", dxf, "--base-body", bodies / "women_size06.obj", "--target-body", bodies / "women_size10.obj",
            "--out", tmp_path / "g", "-q"]
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "no stitches (DXF has none): confirm them in the seams sidecar keiko.seams.json" in err
    # stitches confirmed, but no placements yet
    p = read_dxf_file(dxf).pattern
    side = sidecar_dict(p, propose_stitches(p)[:1])
    side["stitches"][0]["confirmed"] = True
    write_sidecar(tmp_path / "keiko.seams.json", side)
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "no placement for 2 panel(s) ('Detail', 'Detail 2'; DXF has none)" in err and "keiko.seams.json" in err
    assert not (tmp_path / "g").exists()
    # meshing a flat DXF needs neither
    assert run_cli(capsys, "mesh", dxf, "--out", tmp_path / "m", "-q")[0] == 0
