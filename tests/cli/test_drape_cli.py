"""`seamfit drape` on a repository sample: the files it writes and what they hold,
and clean failures."""
from __future__ import annotations

import json

import numpy as np
import pytest

from seamfit import cli
from seamfit.mesh import read_obj
from common import SAMPLES

PATTERN = SAMPLES / "patterns" / "fs_bodice" / "size06" / "pattern.json"
BODY = SAMPLES / "bodies" / "women_size06.obj"


@pytest.fixture(scope="module")
def draped(tmp_path_factory):
    out = tmp_path_factory.mktemp("drape")
    # A coarse mesh and a coarse SDF keep this quick; the defaults are tested elsewhere.
    rc = cli.main(["drape", str(PATTERN), str(BODY), "--out", str(out), "--edge-length", "3",
                   "--sdf-spacing", "0.005", "--tolerance", "1e-3", "-q"])
    return rc, out


def test_drape_writes_obj_report_and_picture(draped):
    rc, out = draped
    report = json.loads((out / "report.json").read_text())
    assert rc == (0 if report["converged"] else 1)
    assert report["converged"], report["message"]
    for key in ("iterations", "seconds", "residual", "max_sewing_gap_mm", "min_phi_mm", "converged",
                "energy_terms", "vertices", "triangles"):
        assert key in report
    assert report["residual"] <= 1e-3
    assert report["max_sewing_gap_mm"] <= 2.0
    assert report["min_phi_mm"] >= -1.0
    assert set(report["energy_terms"]) == {"stretch", "sewing", "bending", "gravity", "sticking", "barrier"}
    obj = read_obj(out / "garment.obj")
    assert obj.positions.shape == (report["vertices"], 3)
    assert len(obj.faces) == report["triangles"]
    assert np.all(np.isfinite(obj.positions))
    # vt are the pattern coordinates (cm), one per vertex
    assert obj.uv.shape == (report["vertices"], 2)
    png = out / "drape.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert report["pictures"] == {"drape.png": {"written": True}} and report["files"]["picture"] == "drape.png"
    # FreeSewing hints were wrapped around the body before sewing
    assert report["dressing"]["wrapped_panels"]
    assert report["coarse_start"] is True


def test_drape_progress_goes_to_stderr(tmp_path, capsys):
    rc = cli.main(["drape", str(PATTERN), str(BODY), "--out", str(tmp_path), "--edge-length", "3",
                   "--sdf-spacing", "0.005", "--max-iterations", "300", "--no-polish", "--no-picture",
                   "--no-coarse-start"])
    err = capsys.readouterr().err
    assert "iteration" in err and "relative residual" in err
    assert rc == 0 and "NOT converged" in err  # 300 iterations are not enough, and it says so
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["converged"] is False and "not converged" in report["message"]
    assert not (tmp_path / "drape.png").exists()
    assert report["pictures"] == {"drape.png": {"written": False, "reason": "--no-picture"}}
    # a pipeline that wants a settled drape asks for a failing exit code
    rc = cli.main(["drape", str(PATTERN), str(BODY), "--out", str(tmp_path), "--force", "--edge-length", "3",
                   "--sdf-spacing", "0.005", "--max-iterations", "300", "--no-polish", "--no-picture",
                   "--no-coarse-start", "-q", "--fail-unconverged"])
    assert rc == 1 and json.loads((tmp_path / "report.json").read_text())["converged"] is False
    assert [s["stage"] for s in report["stages"]] == ["sew", "settle"] and report["coarse_start"] is False


def test_drape_rejects_bad_arguments(tmp_path, capsys):
    assert cli.main(["drape", str(PATTERN), str(BODY), "--out", str(tmp_path), "--edge-length", "-1"]) == 2
    assert "--edge-length" in capsys.readouterr().err
    assert cli.main(["drape", str(tmp_path / "missing.json"), str(BODY), "--out", str(tmp_path)]) == 2
    assert "error" in capsys.readouterr().err


def test_drape_device_runs_or_fails_at_once(tmp_path, capsys):
    """--device cuda drapes where a GPU is present (the report says so) and otherwise
    stops before any work with the reason, writing nothing; --device cpu is recorded."""
    from seamfit._native import core
    out = tmp_path / "gpu"
    args = ["drape", str(PATTERN), str(BODY), "--out", str(out), "--edge-length", "3", "--sdf-spacing", "0.005",
            "--max-iterations", "200", "--no-polish", "--no-coarse-start", "--no-picture", "-q"]
    rc = cli.main(args + ["--device", "cuda"])
    if core().cuda_device_count() > 0:
        assert rc in (0, 1) and json.loads((out / "report.json").read_text())["device"] == "cuda"
    else:
        assert rc == 2
        err = capsys.readouterr().err
        assert "--device cuda" in err and ("no CUDA" in err or "without nvcc" in err)
        assert not out.exists()
    cpu = tmp_path / "cpu"
    args[args.index(str(out))] = str(cpu)
    assert cli.main(args + ["--device", "cpu"]) in (0, 1)
    assert json.loads((cpu / "report.json").read_text())["device"] == "cpu"
