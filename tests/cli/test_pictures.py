"""Results before pictures: a picture that cannot be drawn (matplotlib missing, a drawing
error) is one warning line and a report entry, never a lost result or a traceback."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import seamfit
from seamfit import cli, pictures
from common import SAMPLES

PENCIL = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
QUICK = ["--edge-length", "5", "--sdf-spacing", "0.01"]
# The CLI with matplotlib unimportable, as in a Python that lacks it.
NO_MPL = "import sys; sys.modules['matplotlib'] = None; from seamfit.cli import main; sys.exit(main())"


def run_without_matplotlib(*argv) -> subprocess.CompletedProcess:
    path = [str(Path(seamfit.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in path if p))
    return subprocess.run([sys.executable, "-c", NO_MPL, *map(str, argv)], capture_output=True, text=True,
                          env=env, timeout=900)


def warning_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if "warning:" in line]


def test_drape_without_matplotlib_writes_its_results(tmp_path):
    out = tmp_path / "drape"
    p = run_without_matplotlib("drape", PENCIL, B0, "--out", out, *QUICK, "-q")
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    assert warning_lines(p.stderr) == [p.stderr.strip()]     # -q: the warning is all there is
    assert "drape.png not drawn: matplotlib is not installed" in p.stderr
    assert sorted(f.name for f in out.iterdir()) == ["garment.obj", "report.json"]
    report = json.loads((out / "report.json").read_text())
    assert report["pictures"] == {"drape.png": {"written": False, "reason": pictures.NOT_INSTALLED}}
    assert "picture" not in report["files"]


def test_grade_without_matplotlib_writes_its_results(tmp_path):
    out = tmp_path / "grade"
    p = run_without_matplotlib("grade", PENCIL, "--base-body", B0, "--target-body", B1, "--out", out, *QUICK,
                               "--max-iterations", "2")
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    (line,) = [w for w in warning_lines(p.stderr) if "not drawn" in w]   # one line for both pictures
    assert line.startswith("seamfit grade: warning: pattern.png, drape.png not drawn: matplotlib is not installed")
    assert sorted(f.name for f in out.iterdir()) == ["garment.obj", "pattern.json", "pattern.svg", "report.json"]
    report = json.loads((out / "report.json").read_text())
    assert report["pictures"] == {name: {"written": False, "reason": pictures.NOT_INSTALLED}
                                  for name in ("pattern.png", "drape.png")}
    (wrote,) = [line for line in p.stderr.splitlines() if line.startswith("wrote ")]
    assert wrote.endswith("garment.obj, report.json")                 # lists no picture


def test_a_drawing_error_costs_only_the_picture(tmp_path, capsys, monkeypatch):
    import seamfit.sim

    def broken(path, *a, **k):
        Path(path).write_bytes(b"half a picture")
        raise ValueError("no room on the canvas\nsecond line")
    monkeypatch.setattr(seamfit.sim, "render_drape", broken)     # the name the command uses
    out = tmp_path / "drape"
    assert cli.main(["drape", str(PENCIL), str(B0), "--out", str(out), *QUICK, "-q"]) == 0
    err = capsys.readouterr().err
    assert err == ("seamfit drape: warning: drape.png not drawn: drawing failed (ValueError: no room on the "
                   "canvas); the other results are written\n")
    assert sorted(f.name for f in out.iterdir()) == ["garment.obj", "report.json"]   # no half picture
    assert json.loads((out / "report.json").read_text())["pictures"]["drape.png"] == {
        "written": False, "reason": "drawing failed (ValueError: no room on the canvas)"}


def test_draw_pictures_keeps_drawing_after_a_failure(tmp_path, capsys):
    def fine(path):
        path.write_bytes(b"png")

    def no_pillow(path):
        raise ModuleNotFoundError("No module named 'PIL'", name="PIL")

    def no_mpl(path):
        raise ModuleNotFoundError("No module named 'matplotlib.pyplot'", name="matplotlib.pyplot")
    status = pictures.draw_pictures(tmp_path, {"a.png": no_pillow, "b.png": fine, "c.png": no_mpl},
                                    command="grade")
    assert status == {"a.png": {"written": False,
                                "reason": "matplotlib cannot be imported (ModuleNotFoundError: No module named 'PIL')"},
                      "b.png": {"written": True},
                      "c.png": {"written": False, "reason": pictures.NOT_INSTALLED}}
    assert pictures.written(status) == ["b.png"]
    assert [f.name for f in tmp_path.iterdir()] == ["b.png"]
    assert len(capsys.readouterr().err.splitlines()) == 2      # one line per reason


def test_an_interrupt_while_drawing_still_aborts_the_set(tmp_path):
    def interrupted(path):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        pictures.draw_pictures(tmp_path, {"a.png": interrupted}, command="drape")


def test_no_picture_is_recorded_without_a_warning(capsys):
    assert pictures.skipped(["drape.png"]) == {"drape.png": {"written": False, "reason": "--no-picture"}}
    pictures.warn_missing(pictures.skipped(["drape.png"]), "drape")
    assert capsys.readouterr().err == ""


def _drape_picture_pixels(path, x, mesh, body):
    """render_drape's picture as (H, W, 3) floats in 0..1 and, per view (front, side, back),
    its cloth pixels (coloured) and skin pixels (grey, not white)."""
    from matplotlib.image import imread
    from seamfit.sim.render import render_drape
    render_drape(path, x, mesh.triangles, mesh.triangle_panel, body.vertices if body else None,
                 body.faces if body else None, title="test")
    img = imread(path)[..., :3]
    spread = img.max(axis=2) - img.min(axis=2)
    cloth = spread > 0.15
    skin = (spread < 0.05) & (img.mean(axis=2) < 0.9)
    w = img.shape[1] // 3
    return img, [(int(cloth[:, k * w:(k + 1) * w].sum()), int(skin[:, k * w:(k + 1) * w].sum()))
                 for k in range(3)]


def test_drape_picture_shows_the_garment_over_the_body(tmp_path):
    """The views show cloth and skin; cloth moved in front of the body covers it in
    the front view and is hidden behind it in the back view (painter's order)."""
    from seamfit.body import load_body
    from seamfit.mesh import build_sewn_mesh
    from seamfit.pattern import load_pattern
    mesh = build_sewn_mesh(load_pattern(PENCIL), 3.0)
    body = load_body(B1)
    img, views = _drape_picture_pixels(tmp_path / "drape.png", mesh.x0, mesh, body)
    assert img.shape == (572, 1210, 3)                        # 11 x 5.2 in at 110 dpi
    assert (tmp_path / "drape.png").stat().st_size > 10_000
    front, side, back = views
    assert front[0] > 5_000 and back[0] > 5_000               # the start's flat panels: edge-on from the side
    assert min(skin for _, skin in views) > 5_000

    ahead = mesh.x0 + [0.0, -0.3, 0.0]                        # 30 cm toward the front view
    _, (front_a, side_a, back_a) = _drape_picture_pixels(tmp_path / "ahead.png", ahead, mesh, body)
    assert front_a[0] >= 0.95 * front[0]                      # all of the skirt still shows
    assert front_a[1] < front[1]                              # ... and covers more of the body
    assert back_a[0] < 0.5 * back[0]                          # the body hides most of it from behind

    _, alone = _drape_picture_pixels(tmp_path / "alone.png", mesh.x0, mesh, None)
    assert max(v[1] for v in alone) < 1_000                   # no body: only the titles' grey edges
    assert alone[0][0] > 5_000 and alone[2][0] > 5_000
