"""Body fields cropped to the garment's region (GradeSettings.sdf_region): the crop agrees
with the whole body's field inside it, "auto" crops only when the whole grid is over the
builder's node limit, the region holds the garment with its margin, bad values are refused
and a garment that leaves a cropped field is caught."""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit.body import build_sdf, load_body
from seamfit.body import sdf as sdf_mod
from seamfit.cli import main
from seamfit.errors import SolveError
from seamfit.mesh import build_sewn_mesh
from seamfit.opt import prepare as prep
from seamfit.opt import sdf_region as reg
from seamfit.opt.grade import GradeSettings
from seamfit.pattern import load_pattern

from sim_helpers import fresh_sdf_cache  # noqa: F401 (a fixture)
from test_sdf import BAND_TOL, NODE_TOL
from common import SAMPLES

B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
SKIRT = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
BODICE = SAMPLES / "patterns/fs_bodice/size06/pattern.json"   # hint placements: wrapped around the body
H = 0.005
BAND = (0.60, 0.90)    # a garment's height band (m) for the field tests
MARGIN = 0.05


# Every test builds its fields afresh (sim_helpers.fresh_sdf_cache).
pytestmark = pytest.mark.usefixtures("fresh_sdf_cache")


@pytest.fixture(scope="module")
def body():
    return load_body(B0)


@pytest.fixture(scope="module")
def fields(body):
    whole = build_sdf(body, spacing=H, cache=False)
    crop = build_sdf(body, spacing=H, bounds=reg.garment_bounds(body, H, BAND, MARGIN), cache=False)
    return whole, crop


def test_crop_agrees_with_the_whole_body_field(fields):
    whole, crop = fields
    # the crop's nodes are the whole grid's nodes: same x, y, a run of its z layers
    assert crop.dims[:2] == whole.dims[:2] and np.allclose(crop.origin[:2], whole.origin[:2])
    k0 = (crop.origin[2] - whole.origin[2]) / H
    assert abs(k0 - round(k0)) < 1e-9 and crop.dims[2] < whole.dims[2]
    k0 = int(round(k0))
    ref = whole.values[k0:k0 + crop.dims[2]]
    diff = np.abs(crop.values.astype(np.float64) - ref)
    # Within the exact band both hold exact distances (float32 rounding apart); beyond it
    # both hold propagated ones, each within NODE_TOL of exact (tests/body/test_sdf.py), and the
    # crop's cut faces are seeded exactly, so they may differ there by up to twice that.
    band = np.abs(ref) < 1.5 * H
    assert band.sum() > 1000
    assert diff[band].max() <= BAND_TOL
    assert diff.max() <= 2 * NODE_TOL
    assert np.array_equal(crop.values < 0, ref < 0)
    # samples inside the crop, as the simulator reads them
    rng = np.random.default_rng(3)
    lo, hi = crop.bounds
    P = rng.uniform(lo, hi, size=(4000, 3))
    a, b = crop.sample(P)[0], whole.sample(P)[0]
    assert np.max(np.abs(a - b)) <= 2 * NODE_TOL
    near = np.abs(b) < 0.5 * H  # all eight corners in the exact band
    assert near.sum() > 10 and np.max(np.abs(a - b)[near]) <= 1e-5


def test_auto_picks_the_whole_body_unless_its_grid_is_too_large(body, monkeypatch):
    whole = int(np.prod(reg.whole_body_layout(body, H)[1]))
    assert whole <= sdf_mod.MAX_NODES
    assert reg.resolve_sdf_region("auto", body, H) == "body"
    assert reg.resolve_sdf_region("garment", body, H) == "garment"
    monkeypatch.setattr(sdf_mod, "MAX_NODES", whole - 1)
    assert reg.resolve_sdf_region("auto", body, H) == "garment"
    assert reg.resolve_sdf_region("body", body, H) == "body"
    monkeypatch.setattr(sdf_mod, "MAX_NODES", whole)
    assert reg.resolve_sdf_region("auto", body, H) == "body"


def test_auto_crops_at_the_spacing_a_300k_mesh_needs(body):
    # 1.25 mm: the whole body's grid is over the builder's limit, the garment's band is not
    origin, dims = reg.whole_body_layout(body, 0.00125)
    assert int(np.prod(dims)) > sdf_mod.MAX_NODES
    assert reg.resolve_sdf_region("auto", body, 0.00125) == "garment"
    b = reg.garment_bounds(body, 0.00125, BAND)
    nz = round((b[5] - b[2]) / 0.00125) + 1
    assert dims[0] * dims[1] * nz <= sdf_mod.MAX_NODES


@pytest.mark.parametrize("pattern_path", [SKIRT, BODICE])
def test_region_holds_the_garment_with_the_margin(body, pattern_path):
    pattern = load_pattern(pattern_path)
    mesh = build_sewn_mesh(pattern, edge_length_cm=4)
    z_lo, z_hi = reg.placement_z_range(mesh, pattern, body)
    assert z_lo <= mesh.x0[:, 2].min() and z_hi >= mesh.x0[:, 2].max()
    sdf, info = reg.body_field(body, H, "garment", z_range=(z_lo, z_hi))
    lo, hi = sdf.bounds
    w = np.asarray(info["whole_body_bounds"])
    m = reg.GARMENT_REGION_MARGIN
    # the band +- the margin, out to the next node, unless the body's own box ends first
    assert lo[2] <= z_lo - m + 1e-9 or abs(lo[2] - w[2]) < 1e-9
    assert hi[2] >= z_hi + m - 1e-9 or abs(hi[2] - w[5]) < 1e-9
    assert lo[2] > z_lo - m - H and (hi[2] < z_hi + m + H or abs(hi[2] - w[5]) < 1e-9)
    assert lo[2] >= w[2] - 1e-9 and hi[2] <= w[5] + 1e-9
    # the full horizontal extent
    assert np.allclose(lo[:2], w[:2]) and np.allclose(hi[:2], w[3:5])
    assert info["nodes"] < info["whole_body_nodes"] and info["nodes"] == int(sdf.values.size)
    # the placed garment itself is inside
    assert reg.distance_outside_field(info, mesh.x0) == 0.0


def test_region_is_clamped_to_the_body_box(body):
    origin, dims = reg.whole_body_layout(body, H)
    top = origin[2] + H * (dims[2] - 1)
    b = reg.garment_bounds(body, H, (top - 0.1, top + 0.5))
    assert abs(b[5] - top) < 1e-9 and b[2] < top - 0.1 - reg.GARMENT_REGION_MARGIN + 1e-9
    assert reg.garment_bounds(body, H, (origin[2] - 1, top + 1)) is None  # nothing to cut


def test_invalid_region_is_refused(body, tmp_path):
    with pytest.raises(SolveError, match=r"sdf_region 'cropped'.*auto.*body.*garment"):
        GradeSettings(sdf_region="cropped").validate()
    with pytest.raises(SolveError, match="sdf_region"):
        reg.resolve_sdf_region("Body", body, H)
    with pytest.raises(SolveError, match="sdf_region_margin"):
        GradeSettings(sdf_region_margin=-0.1).validate()
    with pytest.raises(SystemExit) as exc:
        main(["grade", str(SKIRT), "--base-body", str(B0), "--target-body", str(B1), "--out", str(tmp_path),
              "--sdf-region", "cropped"])
    assert exc.value.code == 2


def test_garment_leaving_the_cropped_field_is_caught(body, fields):
    _, crop = fields
    lo, hi = crop.bounds
    origin, dims = reg.whole_body_layout(body, H)
    info = {"region": "garment", "body": "women_size06", "margin_m": MARGIN, "bounds": [*lo, *hi],
            "whole_body_bounds": [*origin, *(origin + H * (np.asarray(dims) - 1))]}
    rng = np.random.default_rng(0)
    x = rng.uniform(lo + 0.05, hi - 0.05, size=(200, 3))
    assert reg.garment_outside_field(crop, info, x, "base", "at the end of the base drape") is None
    assert info["max_outside_mm"] == 0.0
    x[7, 2] = lo[2] - 0.5 * H          # within the tolerance
    assert reg.garment_outside_field(crop, info, x, "base", "at the end of the base drape") is None
    x[7, 2] = lo[2] - 0.03             # a hem 3 cm below the cut
    msg = reg.garment_outside_field(crop, info, x, "base", "at the end of the base drape")
    assert msg and "30 mm" in msg and "women_size06" in msg and 'sdf_region="body"' in msg
    assert abs(info["max_outside_mm"] - 30.0) < 1e-6
    x[7, 2] = hi[2] + 0.02             # and above the top cut
    assert "20 mm" in reg.garment_outside_field(crop, info, x, "target", "of the result")
    # beyond a face that was not cut (the body's own box) nothing is missing from the field
    x[7] = [hi[0] + 0.3, 0.0, 0.5 * (lo[2] + hi[2])]
    assert reg.garment_outside_field(crop, info, x, "target", "of the result") is None
    assert reg.garment_outside_field(crop, dict(info, region="body"), x - [0, 0, 1], "t", "w") is None


def test_base_drape_outside_the_field_stops_the_grading(monkeypatch):
    """The check is wired in: a base drape that left the cropped field stops prepare, and
    a drape made on that field is dropped from the cache."""
    from seamfit.cache import cache_root, save_arrays

    def fake_drape(mesh, pattern, body, sdf, fabric, settings, **kw):
        save_arrays("drape", "k-fake", {"x": mesh.x0})
        x = np.asarray(mesh.x0, dtype=np.float64).copy()
        x[0, 2] = sdf.bounds[0][2] - 0.05   # one vertex 5 cm below the cut
        return x, {"cached": False, "key": "k-fake", "residual": 0.0, "seconds": 0.0}

    monkeypatch.setattr(prep, "base_drape", fake_drape)
    settings = GradeSettings(edge_length_cm=6, sdf_spacing=0.01, sdf_region="garment", evaluate_base_pattern=False)
    with pytest.raises(SolveError, match=r"end of the base drape.*50 mm.*sdf_region=\"body\""):
        prep.prepare(load_pattern(SKIRT), load_body(B0), load_body(B1), settings)
    assert not (cache_root() / "drape" / "k-fake.npz").exists()


def test_grade_on_cropped_fields(tmp_path):
    """A whole grading (coarse) on cropped fields: the report says where the fields were
    built and how large they are, and the result stayed inside them."""
    out = tmp_path / "out"   # a fresh folder: a used one needs --force
    code = main(["grade", str(SKIRT), "--base-body", str(B0), "--target-body", str(B1), "--out", str(out),
                 "--edge-length", "5", "--sdf-spacing", "0.01", "--max-iterations", "4", "--checkpoint-every", "2",
                 "--sdf-region", "garment", "--no-picture", "-q"])
    assert code == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["settings"]["sdf_region"] == "garment"
    sdf = rep["sdf"]
    assert sdf["requested"] == "garment" and "warning" not in sdf
    for which in ("base", "target"):
        f = sdf[which]
        assert f["region"] == "garment" and 0 < f["nodes"] < f["whole_body_nodes"]
        assert f["nodes"] == int(np.prod(f["dims"]))
        assert f["max_outside_mm"] == 0.0
    assert rep["drape"]["min_phi_mm"] > -5


def test_a_gpu_that_cannot_build_the_field_hands_it_to_the_cpu(monkeypatch):
    """A GPU short of memory (other gradings share it) must not fail the grading: the field
    is built on the CPU, the same bits as a CPU build, and the report entry says so."""
    from seamfit.errors import DeviceError
    import seamfit.body as body_pkg
    real = body_pkg.build_sdf
    asked = []

    def gpu_out_of_memory(body, *, device="cpu", **kw):
        asked.append(device)
        if device == "cuda":
            raise DeviceError("the SDF of 1000 nodes needs 9 MiB of GPU memory, 1 MiB are free")
        return real(body, device=device, **kw)

    monkeypatch.setattr(body_pkg, "build_sdf", gpu_out_of_memory)
    body = load_body(B0)
    sdf, info = reg.body_field(body, 0.02, "body", device="cuda")
    assert asked == ["cuda", "cpu"]
    assert info["built_on"] == "cpu" and "GPU memory" in info["device_note"]
    assert np.array_equal(sdf.values, real(body, spacing=0.02).values)
    # on the CPU nothing is handed on: its errors are the caller's
    monkeypatch.setattr(body_pkg, "build_sdf", lambda *a, **k: (_ for _ in ()).throw(DeviceError("x")))
    with pytest.raises(DeviceError):
        reg.body_field(body, 0.02, "body", device="cpu")
