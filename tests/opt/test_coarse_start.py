"""Coarse-to-fine grading (seamfit.opt.coarse_start): a fine mesh is graded on a coarse
one and the result carried to it through the base pattern's coordinates."""
import json

import numpy as np
import pytest

from seamfit.cli import main
from seamfit.mesh import build_sewn_mesh
from seamfit.opt.coarse_start import carry_pattern, coarse_edge_for
from seamfit.opt.grade import GradeSettings
from seamfit.pattern import load_pattern
from seamfit.pattern.compare import landmark_errors
from common import SAMPLES, SHARED_DATA

SKIRT = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
BODICE = SAMPLES / "patterns/fs_bodice/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"


def test_which_meshes_are_graded_coarse_first():
    assert coarse_edge_for(GradeSettings(edge_length_cm=1.5)) == 3.0           # the default coarse level
    assert coarse_edge_for(GradeSettings(edge_length_cm=0.45)) == 3.0
    assert coarse_edge_for(GradeSettings(edge_length_cm=2.0)) == 0.0           # not twice as fine
    assert coarse_edge_for(GradeSettings()) == 0.0                             # the default mesh itself
    assert coarse_edge_for(GradeSettings(edge_length_cm=1.0, coarse_edge_length_cm=0)) == 0.0
    assert coarse_edge_for(GradeSettings(edge_length_cm=1.0, method="fixed-point")) == 0.0


def _smooth_map(p):
    """A grading-like smooth map of pattern points (metres): stretch, shear and a wave."""
    return p @ np.array([[1.06, 0.01], [0.0, 0.96]]) + 0.002 * np.sin(20.0 * p)


@pytest.mark.parametrize("pattern", [SKIRT, BODICE], ids=["skirt", "darted bodice"])
def test_a_smooth_grading_carries_to_the_fine_boundary(pattern):
    base = load_pattern(pattern)
    coarse, fine = build_sewn_mesh(base, 4.0), build_sewn_mesh(base, 1.5)
    pc, pf = np.asarray(coarse.uv_cm) / 100.0, np.asarray(fine.uv_cm) / 100.0
    carried = carry_pattern(coarse, _smooth_map(pc), fine)
    b = np.asarray(fine.boundary, bool)
    err = np.linalg.norm(carried - _smooth_map(pf), axis=1)
    # the map moves points by up to ~3 cm; along the outline the cubic keeps within 0.5 mm
    assert err[b].max() < 5e-4
    # the base pattern carries to the base pattern exactly
    assert np.allclose(carry_pattern(coarse, pc, fine), pf, atol=1e-12)


def test_the_carried_outline_has_no_kinks_at_the_coarse_vertices():
    """Second differences along each fine outline follow those of the map itself, closer
    than a piecewise-linear carry, which puts a slope jump at every coarse vertex."""
    from seamfit.sim.multilevel import locate

    base = load_pattern(SKIRT)
    coarse, fine = build_sewn_mesh(base, 4.0), build_sewn_mesh(base, 1.0)
    pc, pf = np.asarray(coarse.uv_cm) / 100.0, np.asarray(fine.uv_cm) / 100.0
    carried = carry_pattern(coarse, _smooth_map(pc), fine)
    tri, bary = locate(coarse, fine.uv_cm, fine.vertex_panel)
    linear = pf + np.einsum("mi,mij->mj", bary, (_smooth_map(pc) - pc)[coarse.triangles[tri]])
    corner = np.asarray(fine.corner, bool)

    def worst(p):
        out = 0.0
        for loop in fine.boundary_loops:
            loop = np.asarray(loop)
            prev, nxt = np.roll(loop, 1), np.roll(loop, -1)
            d2 = (p[prev] - 2 * p[loop] + p[nxt]) - (_smooth_map(pf)[prev] - 2 * _smooth_map(pf)[loop]
                                                     + _smooth_map(pf)[nxt])
            smooth = ~corner[loop] & ~corner[prev] & ~corner[nxt]
            out = max(out, float(np.abs(d2)[smooth].max()))
        return out

    assert worst(carried) < 0.5 * worst(linear)     # measured 0.08 against 0.25 mm
    assert worst(carried) < 1.5e-4


@pytest.fixture(scope="module")
def graded_pair(tmp_path_factory):
    """The sample skirt at a 2 cm mesh, coarse-to-fine from 4 cm, and the 4 cm grading alone."""
    common = ["--base-body", str(B0), "--target-body", str(B1), "--sdf-spacing", "0.005",
              "--max-iterations", "32", "--checkpoint-every", "16", "--smo", "0", "--no-picture", "-q"]
    fine, coarse = tmp_path_factory.mktemp("c2f"), tmp_path_factory.mktemp("coarse")
    before = SKIRT.read_bytes()
    assert main(["grade", str(SKIRT), "--out", str(fine), "--edge-length", "2", "--coarse-edge-length", "4",
                 *common]) == 0
    assert main(["grade", str(SKIRT), "--out", str(coarse), "--edge-length", "4", *common]) == 0
    assert SKIRT.read_bytes() == before
    return fine, coarse


def test_the_fine_grading_is_the_coarse_one_carried(graded_pair):
    fine, coarse = graded_pair
    rf = json.loads((fine / "report.json").read_text())
    rc = json.loads((coarse / "report.json").read_text())
    c = rf["coarse_level"]
    assert c["edge_length_cm"] == 4.0 and rf["mesh"]["edge_length_cm"] == 2.0
    assert rf["mesh"]["vertices"] > 2 * c["vertices"]
    # the same search as the coarse grading alone, to the last digit
    assert c["objective_final"] == pytest.approx(rc["objective_final"], rel=1e-12)
    assert c["outer_iterations"] == rc["outer_iterations"]
    # no search on the fine mesh: it ends, converged or not, as the coarse level did
    assert rf["outer_iterations_done"] == 0 and rf["converged"] == rc["converged"]
    assert rf["message"].startswith("coarse level (4 cm)")
    assert rf["start"]["from"] == "coarse level" and "carried" in rf["base_drape"]
    # the written patterns agree to within a millimetre at every landmark
    pf, pc = load_pattern(fine / "pattern.json"), load_pattern(coarse / "pattern.json")
    assert landmark_errors(pf, pc).max_cm < 0.1
    # the fine drape is sewn and outside the body; the stitches agree as the output check asks
    assert rf["drape"]["min_phi_mm"] > -1.0 and rf["drape"]["max_sewing_gap_mm"] < 5.0
    assert all(s["ok"] for s in rf["checks"]["stitches"])


def test_progress_shows_the_coarse_level_as_a_stage():
    from seamfit.progress import GradeProgress, plan_grading

    fine = plan_grading(GradeSettings(edge_length_cm=1.0), 5000)
    assert fine.order[0] == "coarse grading" and fine.seconds["coarse grading"] > 0
    # no search, level scaling or settled base drape on the fine mesh: the coarse level did those
    assert fine.iterations == 0 and "level scaling" not in fine.seconds and fine.seconds["base drape"] == 0
    direct = plan_grading(GradeSettings(), 900)
    assert direct.order[0] == "meshing" and "coarse grading" not in direct.seconds
    # the coarse level's own events count towards its stage, then the fine mesh's stages follow
    t = [0.0]
    tracker = GradeProgress(fine, clock=lambda: t[0])
    seen = []
    for info in ({"stage": "coarse grading", "detail": "mesh"}, {"stage": "coarse grading", "detail": "optimize"},
                 {"stage": "mesh"}, {"stage": "initial drape"}, {"stage": "refit"}):
        t[0] += 1.0
        snap = tracker.observe(info)
        seen.append((snap.stage, snap.index, round(snap.fraction, 6)))
    assert [s for s, _, _ in seen] == ["coarse grading", "coarse grading", "meshing", "initial drapes", "refit"]
    assert seen[0][1] == 1 and seen[2][1] == 2
    assert [f for _, _, f in seen] == sorted(f for _, _, f in seen)


def test_a_size_run_starts_each_coarse_level_from_its_neighbours(tmp_path):
    """grade-run at a fine mesh: every size graded coarse-to-fine, each coarse level after the
    first warm-started from its neighbour's coarse search (seamfit.opt.size_run)."""

    bodies = SHARED_DATA / "bodies"
    targets = [bodies / "women_size10.obj", bodies / "women_size14.obj"]
    out = tmp_path / "run"
    assert main(["grade-run", str(SKIRT), "--base-body", str(B0), "--target-bodies", *map(str, targets),
                 "--out", str(out), "--edge-length", "2.5", "--coarse-edge-length", "5", "--sdf-spacing", "0.01",
                 "--max-iterations", "4", "--checkpoint-every", "2", "--no-picture", "-q"]) == 0
    reports = {p.parent.name: json.loads(p.read_text()) for p in out.glob("*/report.json")}
    assert len(reports) == 2
    levels = sorted(r["coarse_level"]["warm_start"] for r in reports.values())
    assert levels == [False, True]
    assert all(r["mesh"]["edge_length_cm"] == 2.5 and r["coarse_level"]["edge_length_cm"] == 5.0
               for r in reports.values())


def test_a_pattern_the_coarse_level_cannot_mesh_is_graded_directly(monkeypatch):
    """A panel too narrow for the coarse edge: the requested mesh is graded as it always was,
    and the report says why."""
    import seamfit.opt.prepare as prepare_module
    from seamfit.body import load_body
    from seamfit.errors import PatternError
    from seamfit.opt.grade import grade

    real = prepare_module.build_sewn_mesh

    def narrow(pattern, edge_length_cm=3.0, **kw):
        if edge_length_cm >= 8.0:
            raise PatternError("panel 'skirt_front': only 2 boundary vertices at edge 8 cm")
        return real(pattern, edge_length_cm=edge_length_cm, **kw)

    monkeypatch.setattr(prepare_module, "build_sewn_mesh", narrow)
    settings = GradeSettings(edge_length_cm=4.0, coarse_edge_length_cm=8.0, sdf_spacing=0.01,
                             max_outer_iterations=2, checkpoint_every=1, device="cpu")
    res = grade(load_pattern(SKIRT), load_body(B0), load_body(B1), settings)
    rep = res.report
    assert "could not be meshed" in rep["coarse_level"]["skipped"] and "only 2 boundary vertices" in rep["coarse_level"]["skipped"]
    assert rep["mesh"]["edge_length_cm"] == 4.0 and rep["outer_iterations_done"] > 0
    assert rep["start"]["from"] == "level scaling"
