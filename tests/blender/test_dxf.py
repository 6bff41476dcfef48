# SPDX-License-Identifier: GPL-3.0-or-later
"""DXF-AAMA/ASTM through the add-on: import (one size, a chosen size of a multi-size file),
proposed stitches confirmed into the scene's pattern, export with seam allowance."""
import shutil

import bpy
import numpy as np
import pytest

from helpers import KEIKO, addon, bezier_world, file_digest

TOL_CM = 0.01           # 0.1 mm


def _library(path, size=None):
    from seamfit.pattern.dxf_sizes import one_size, read_dxf_sizes
    return one_size(read_dxf_sizes(path), size)


def _pattern_collections():
    return [c for c in bpy.data.collections if "seamfit_pattern" in c]


def _assert_matches_file(coll, expected):
    """Panel count, and every panel's curve points and outline within 0.1 mm of the file's."""
    sio = addon().scene_io
    objs = sio.panel_objects(coll)
    assert sorted(objs) == sorted(p.name for p in expected.panels)
    shown = sio.pattern_from_collection(coll)
    for pn in expected.panels:
        starts = sorted(e.start for e in pn.edges)
        nodes_cm = 100.0 * bezier_world(objs[pn.name])[:, :2]     # DXF panels lie flat at the origin
        assert np.abs(nodes_cm - pn.outline_cm[starts]).max() < TOL_CM
        got = shown.panel(pn.name).outline_cm
        assert got.shape == pn.outline_cm.shape and np.abs(got - pn.outline_cm).max() < TOL_CM


@pytest.fixture()
def keiko(tmp_path):
    """The shared AAMA file, copied so that no seams sidecar lies beside it."""
    path = tmp_path / KEIKO.name
    shutil.copy(KEIKO, path)
    return path


def test_import_dxf_proposes_stitches_to_confirm(scene, keiko):
    digest = file_digest(keiko)
    assert bpy.ops.seamfit.import_pattern(filepath=str(keiko)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    expected = _library(keiko)
    _assert_matches_file(coll, expected)
    info = coll.seamfit
    assert len(info.panels) == 2 and len(info.stitches) == 0
    # No sidecar: the library's proposals, none accepted yet.
    from seamfit.pattern.seams import propose_stitches
    proposed = propose_stitches(expected)
    assert len(info.proposals) == len(proposed) == 3
    assert [(p.panel_a, p.panel_b) for p in info.proposals] == [(e["a"]["panel"], e["b"]["panel"]) for e in proposed]
    assert not any(p.accept for p in info.proposals)

    # Without confirmed stitches it is not draped: the library's one line, nothing built.
    bpy.ops.mesh.primitive_cube_add()
    scene.seamfit.base_body = bpy.context.active_object
    n_coll = len(bpy.data.collections)
    with pytest.raises(RuntimeError, match=r"no stitches \(DXF has none\): confirm them in the seams sidecar"):
        bpy.ops.seamfit.drape()
    assert len(bpy.data.collections) == n_coll

    with pytest.raises(RuntimeError, match="no proposed stitch accepted"):
        bpy.ops.seamfit.confirm_stitches(collection=coll.name)
    info.proposals[0].accept = info.proposals[1].accept = True
    assert bpy.ops.seamfit.confirm_stitches(collection=coll.name) == {"FINISHED"}
    assert len(info.proposals) == 0 and len(info.stitches) == 2
    pattern = addon().scene_io.pattern_from_collection(coll)
    assert [(s.a.panel, s.b.panel) for s in pattern.stitches] == [(e["a"]["panel"], e["b"]["panel"])
                                                                   for e in proposed[:2]]
    (stitch_obj,) = [o for o in coll.objects if o.type == "MESH"]
    assert len(stitch_obj.data.edges) > 0
    # Stitched, still unplaced: the library's next line names the panels.
    with pytest.raises(RuntimeError, match=r"no placement for 2 panel\(s\)"):
        bpy.ops.seamfit.drape()
    assert file_digest(keiko) == digest and sorted(p.name for p in keiko.parent.iterdir()) == [keiko.name]


def test_import_dxf_reads_the_seams_sidecar(scene, keiko):
    from seamfit.pattern.seams import propose_stitches, sidecar_dict, sidecar_path, write_sidecar
    entries = propose_stitches(_library(keiko))[:1]
    entries[0]["confirmed"] = True
    write_sidecar(sidecar_path(keiko), sidecar_dict(_library(keiko), entries))
    assert bpy.ops.seamfit.import_pattern(filepath=str(keiko)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    assert len(coll.seamfit.stitches) == 1 and len(coll.seamfit.proposals) == 0


@pytest.fixture()
def two_sizes(tmp_path):
    """A multi-size DXF-ASTM made by the library's writer: the shared pattern at two scales."""
    from seamfit.pattern.dxf_sizes import write_size_run_dxf
    from seamfit.pattern.scale import scale_pattern
    base = _library(KEIKO)
    big = scale_pattern(base, 1.06, 1.03)
    path = tmp_path / "keiko_run.astm.dxf"
    write_size_run_dxf(path, [base, big], ["S", "L"], 0)
    return path


def test_import_multi_size_dxf_asks_the_size(scene, two_sizes):
    op = addon().operators
    assert [it[0] for it in op._file_sizes(type("Op", (), {"filepath": str(two_sizes)})(), None)] == ["S", "L"]
    with pytest.raises(TypeError):                  # only the file's sizes can be chosen
        bpy.ops.seamfit.import_pattern(filepath=str(two_sizes), size="XL")
    assert bpy.ops.seamfit.import_pattern(filepath=str(two_sizes), size="L") == {"FINISHED"}
    (coll,) = _pattern_collections()
    assert coll.seamfit.size == "L" and coll.name.endswith(" L")
    _assert_matches_file(coll, _library(two_sizes, "L"))
    small = _library(two_sizes, "S")
    assert all(np.ptp(p.outline_cm[:, 0]) > np.ptp(small.panel(p.name).outline_cm[:, 0]) + 1.0
               for p in _library(two_sizes, "L").panels)


@pytest.mark.parametrize("fmt,corners", [("DXF_ASTM", "square"), ("DXF_AAMA", "mitre")])
def test_export_dxf_with_seam_allowance(scene, keiko, tmp_path, fmt, corners):
    assert bpy.ops.seamfit.import_pattern(filepath=str(keiko)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    ext = addon().dxf_io.EXPORT_FORMATS[fmt][0]
    out = tmp_path / "out" / f"keiko{ext}"
    out.parent.mkdir()
    assert bpy.ops.seamfit.export_pattern(filepath=str(out), collection=coll.name, format=fmt,
                                          use_allowance=True, allowance_cm=1.5, corners=corners) == {"FINISHED"}
    # No stitches yet: the DXF alone, no sidecar.
    assert sorted(p.name for p in out.parent.iterdir()) == [out.name]
    from seamfit.pattern.allowance import cut_line
    back, src = _library(out), _library(keiko)
    assert back.extra["source"]["format"] == f"dxf-{addon().dxf_io.EXPORT_FORMATS[fmt][1]}"
    assert [p.name for p in back.panels] == [p.name for p in src.panels]
    for pn in src.panels:
        got = back.panel(pn.name)
        assert got.outline_cm.shape == pn.outline_cm.shape and np.abs(got.outline_cm - pn.outline_cm).max() < TOL_CM
        # The cut line (layer 1, the seam line on 14) is the library's for 1.5 cm and these corners.
        cut, want = np.asarray(got.extra["dxf"]["cut_line_cm"]), cut_line(pn, 1.5, corners)
        assert cut.shape == want.shape and np.abs(cut - want).max() < TOL_CM
        assert np.median([e.extra["seam_allowance_cm"] for e in got.edges]) == pytest.approx(1.5, abs=0.01)


def test_export_never_over_the_input(scene, keiko):
    assert bpy.ops.seamfit.import_pattern(filepath=str(keiko)) == {"FINISHED"}
    (coll,) = _pattern_collections()
    digest = file_digest(keiko)
    with pytest.raises(RuntimeError, match="would replace the input"):
        bpy.ops.seamfit.export_pattern(filepath=str(keiko), collection=coll.name, format="DXF_AAMA")
    assert file_digest(keiko) == digest
    with pytest.raises(RuntimeError, match=r"must end in \.dxf"):
        bpy.ops.seamfit.export_pattern(filepath=str(keiko.with_name("k.json")), collection=coll.name,
                                       format="DXF_ASTM")
    assert sorted(p.name for p in keiko.parent.iterdir()) == [keiko.name]
