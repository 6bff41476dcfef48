"""Commands never modify their inputs and never leave a half-written or mixed result:
outputs that would replace an input are refused, existing results are replaced only with
--force and then whole, interrupts (SIGINT, SIGTERM) leave nothing behind, and output paths
that cannot be written fail before any computation."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import seamfit
from seamfit import cli
from seamfit.output_set import OutputSet
from common import SAMPLES

PENCIL = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
CIRCLE = SAMPLES / "patterns/gc_circle_skirt/size06/pattern.json"
TRUTH = SAMPLES / "patterns/gc_pencil_skirt/size10/pattern.json"
B0 = SAMPLES / "bodies/women_size06.obj"
B1 = SAMPLES / "bodies/women_size10.obj"
# Quick settings: every run here either stops before computing or is killed early.
GRADE_QUICK = ["--edge-length", "5", "--sdf-spacing", "0.01", "--no-picture"]
FAST_S = 5.0   # a refusal takes well under this; the quickest computation here takes longer


def run(capsys, *argv):
    t0 = time.perf_counter()
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, err, time.perf_counter() - t0


def leftovers(folder: Path) -> list[str]:
    """Temporary folders or files of an output set or an atomic write, anywhere below."""
    return [str(p) for p in folder.rglob("*") if ".seamfit-tmp-" in p.name or ".seamfit-old-" in p.name
            or p.name.endswith(".tmp")]


def one_line_error(err: str, *names) -> None:
    assert "Traceback" not in err
    assert err.count("\n") == 1 and "error:" in err, err
    for n in names:
        assert str(n) in err, (n, err)


# ----------------------------------------------------------------- 1: inputs are never replaced

def grade_args(pattern, out, *extra, base=B0, target=B1):
    return ["grade", pattern, "--base-body", base, "--target-body", target, "--out", out, *GRADE_QUICK, *extra]


@pytest.mark.parametrize("force", [False, True])
def test_grade_into_its_input_folder_is_refused(tmp_path, capsys, force):
    """The issue's case: every sample pattern is pattern.json, and grade writes pattern.json."""
    d = tmp_path / "job"
    d.mkdir()
    src = d / "pattern.json"
    src.write_bytes(PENCIL.read_bytes())
    before = src.read_bytes()
    code, err, secs = run(capsys, *grade_args(src, d, *(["--force"] if force else [])))
    assert code == 2 and secs < FAST_S
    one_line_error(err, src, "would replace the input")
    assert src.read_bytes() == before and sorted(p.name for p in d.iterdir()) == ["pattern.json"]
    assert not leftovers(tmp_path)


def test_every_input_counts_through_links(tmp_path, capsys):
    """Bodies and --truth are inputs too, found through a symlinked --out or a hard link."""
    res = tmp_path / "res"
    res.mkdir()
    body = res / "target.obj"
    body.write_bytes(B1.read_bytes())
    link = tmp_path / "link"
    link.symlink_to(res, target_is_directory=True)
    code, err, _ = run(capsys, *grade_args(PENCIL, link, "--force", target=body))
    assert code == 2
    one_line_error(err, body)
    # --truth hard-linked into the folder --out would replace
    hard = res / "truth.json"
    hard.write_bytes(TRUTH.read_bytes())
    outside = tmp_path / "truth_outside.json"
    os.link(hard, outside)
    code, err, _ = run(capsys, *grade_args(PENCIL, res, "--force", "--truth", outside))
    assert code == 2
    one_line_error(err, outside, "hard link")
    assert body.read_bytes() == B1.read_bytes() and hard.read_bytes() == TRUTH.read_bytes()


@pytest.mark.parametrize("command", ["mesh", "drape"])
def test_mesh_and_drape_refuse_their_input_folder(tmp_path, capsys, command):
    src = tmp_path / "pattern.json"
    src.write_bytes(CIRCLE.read_bytes())
    argv = [command, src] + ([B0] if command == "drape" else []) + ["--out", tmp_path, "--force"]
    code, err, secs = run(capsys, *argv)
    assert code == 2 and secs < FAST_S
    one_line_error(err, src)
    assert src.read_bytes() == CIRCLE.read_bytes()


def test_sdf_refuses_to_replace_its_body(tmp_path, capsys):
    body = tmp_path / "b.obj"
    body.write_bytes(B0.read_bytes())
    alias = tmp_path / "b.json"          # the report's name, hard-linked to the body
    os.link(body, alias)
    code, err, _ = run(capsys, "sdf", alias, "--out", tmp_path / "b.npz", "--spacing", "0.02", "--force")
    assert code == 2
    one_line_error(err, "b.json")
    assert body.read_bytes() == B0.read_bytes()


@pytest.mark.parametrize("option", ["--svg", "--fix"])
def test_validate_does_not_write_over_the_file_it_checks(tmp_path, capsys, option):
    src = tmp_path / "p.json"
    src.write_bytes(CIRCLE.read_bytes())
    link = tmp_path / "link.json"
    link.symlink_to(src)
    for out in (src, link):
        code, err, _ = run(capsys, "validate", src, option, out, "-q")
        assert code == 2
        one_line_error(err, out, "would replace the input")
    assert src.read_bytes() == CIRCLE.read_bytes()


# ----------------------------------------------------------------- 2: sdf keeps an existing report

def test_sdf_does_not_overwrite_a_json_beside_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    mine = tmp_path / "x.json"
    mine.write_text('{"mine": true}\n')
    code, err, secs = run(capsys, "sdf", B0, "--out", tmp_path / "x.npz", "--spacing", "0.02")
    assert code == 2 and secs < FAST_S
    one_line_error(err, mine, "--force")
    assert mine.read_text() == '{"mine": true}\n' and not (tmp_path / "x.npz").exists()
    # with --force, both are written, and the report is the field's
    code, err, _ = run(capsys, "sdf", B0, "--out", tmp_path / "x.npz", "--spacing", "0.02", "--force")
    assert code == 0, err
    assert json.loads(mine.read_text())["spacing"] == 0.02 and (tmp_path / "x.npz").exists()
    # an existing .npz alone is kept too
    mine.unlink()
    npz = (tmp_path / "x.npz").read_bytes()
    code, err, _ = run(capsys, "sdf", B0, "--out", tmp_path / "x.npz", "--spacing", "0.03")
    assert code == 2 and "x.npz" in err and (tmp_path / "x.npz").read_bytes() == npz
    assert not mine.exists() and not leftovers(tmp_path)


# ----------------------------------------------------------------- 3: whole sets, --force

def test_an_existing_result_folder_needs_force_and_is_replaced_whole(tmp_path, capsys):
    out = tmp_path / "mesh"
    out.mkdir()
    (out / "report.json").write_text("old")
    (out / "stale.txt").write_text("from another run")
    code, err, secs = run(capsys, "mesh", CIRCLE, "--out", out, "--edge-length", "4", "-q")
    assert code == 2 and secs < FAST_S
    one_line_error(err, out, "--force")
    assert (out / "report.json").read_text() == "old" and (out / "stale.txt").exists()
    code, err, _ = run(capsys, "mesh", CIRCLE, "--out", out, "--edge-length", "4", "-q", "--force")
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["mesh.obj", "pattern.svg", "report.json"]
    assert json.loads((out / "report.json").read_text())["edge_length_cm"] == 4
    assert oct(out.stat().st_mode & 0o777) == oct(0o777 & ~_umask())
    assert not leftovers(tmp_path)
    # an empty folder (a fresh tmp dir, say) is not a result: no --force needed
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run(capsys, "mesh", CIRCLE, "--out", empty, "--edge-length", "4", "-q")[0] == 0
    assert (empty / "mesh.obj").exists()


def test_a_run_failing_half_way_leaves_no_trace(tmp_path, capsys, monkeypatch):
    """The target body in centimetres is refused inside the grading, after the output set was
    opened (and its parent folders made): all of it is removed again."""
    from seamfit.body import load_body, save_body
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    body = load_body(B1)
    body.vertices = body.vertices * 100.0
    cm = save_body(body, tmp_path / "target_in_cm.obj")
    out = tmp_path / "a" / "b" / "out"
    code, err, _ = run(capsys, *grade_args(PENCIL, out, "-q", target=cm))
    assert code == 2 and "target_in_cm.obj" in err
    assert not (tmp_path / "a").exists() and not leftovers(tmp_path)


def test_output_set_cleans_up_on_any_exception(tmp_path):
    out = tmp_path / "new" / "out"
    with pytest.raises(KeyboardInterrupt):
        with OutputSet(out) as tmp:
            (tmp / "half.txt").write_text("x")
            raise KeyboardInterrupt
    assert not (tmp_path / "new").exists()     # its parent was made for it, and removed too
    old = tmp_path / "old"
    old.mkdir()
    (old / "a.txt").write_text("old")
    with pytest.raises(RuntimeError):
        with OutputSet(old, force=True) as tmp:
            (tmp / "a.txt").write_text("new")
            raise RuntimeError("failed half way")
    assert (old / "a.txt").read_text() == "old" and not leftovers(tmp_path)


def test_the_sigterm_handler_is_put_back(tmp_path, capsys):
    before = signal.getsignal(signal.SIGTERM)
    run(capsys, "mesh", tmp_path / "missing.json", "--out", tmp_path / "o")
    assert signal.getsignal(signal.SIGTERM) is before


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# ----------------------------------------------------------------- 3: interrupts

def _start(argv, tmp_path):
    # the seamfit this test imported (installed or the source tree), in the child too
    here = str(Path(seamfit.__file__).resolve().parents[1])
    env = dict(os.environ, SEAMFIT_CACHE_DIR=str(tmp_path / "cache"), PYTHONUNBUFFERED="1",
               PYTHONPATH=os.pathsep.join([here] + sys.path))
    # A shell without job control starts background commands (CI scripts, `pytest &`) with
    # SIGINT ignored, and an ignored signal stays ignored across exec: give the child the
    # default a user's Ctrl-C meets, or it would rightly ignore the test's SIGINT too.
    return subprocess.Popen([sys.executable, "-m", "seamfit", *map(str, argv)], env=env, cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _interrupt_when_computing(proc, parent: Path, name: str, sig) -> tuple[int, str]:
    """Wait until the temporary folder exists and the computation has begun, then signal."""
    deadline = time.monotonic() + 60
    while not list(parent.glob(f".{name}.seamfit-tmp-*")):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no temporary output folder appeared"
        time.sleep(0.05)
    time.sleep(1.0)                      # inside the mesh, SDF or simulation by now
    assert proc.poll() is None, "the run ended before it could be interrupted"
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    return proc.returncode, err


@pytest.mark.parametrize("sig,code,word", [(signal.SIGTERM, 143, "terminated"),
                                           (signal.SIGINT, 130, "interrupted")])
def test_an_interrupted_grade_leaves_nothing(tmp_path, sig, code, word):
    out = tmp_path / "out"
    proc = _start(grade_args(PENCIL, out, "--max-iterations", "100000", "-q"), tmp_path)
    rc, err = _interrupt_when_computing(proc, tmp_path, "out", sig)
    assert rc == code, err
    assert err.strip().count("\n") == 0 and word in err and "Traceback" not in err, err
    assert not out.exists()
    assert not leftovers(tmp_path), leftovers(tmp_path)   # beside --out and in the cache


def test_an_interrupted_drape_keeps_the_old_set(tmp_path):
    out = tmp_path / "drape"
    out.mkdir()
    (out / "report.json").write_text('{"old": true}')
    (out / "garment.obj").write_text("# old\n")
    argv = ["drape", PENCIL, B0, "--out", out, "--edge-length", "4", "--sdf-spacing", "0.01",
            "--tolerance", "1e-12", "--max-iterations", "10000000", "--no-coarse-start", "--no-polish",
            "--no-picture", "--force", "-q"]
    proc = _start(argv, tmp_path)
    rc, err = _interrupt_when_computing(proc, tmp_path, "drape", signal.SIGTERM)
    assert rc == 143 and "terminated" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["garment.obj", "report.json"]
    assert (out / "report.json").read_text() == '{"old": true}'
    assert not leftovers(tmp_path), leftovers(tmp_path)


# ----------------------------------------------------------------- output paths that cannot work

@pytest.mark.parametrize("command", ["mesh", "sdf", "drape", "grade"])
def test_an_output_under_a_regular_file_fails_before_computing(tmp_path, capsys, command):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    target = blocker / "sub" / ("x.npz" if command == "sdf" else "out")
    argv = {"mesh": ["mesh", CIRCLE, "--out", target, "--edge-length", "4"],
            "sdf": ["sdf", B0, "--out", target, "--spacing", "0.01"],
            "drape": ["drape", CIRCLE, B0, "--out", target, "--edge-length", "4"],
            "grade": grade_args(PENCIL, target)}[command]
    code, err, secs = run(capsys, *argv)
    assert code == 2 and secs < FAST_S
    one_line_error(err, blocker)
    assert blocker.read_text() == "not a folder"


def test_a_read_only_parent_fails_before_computing(tmp_path, capsys, monkeypatch):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    if os.geteuid() == 0:
        # root may write into a read-only folder: refuse as the kernel refuses everyone else.
        import tempfile
        real_mkdtemp = tempfile.mkdtemp

        def mkdtemp(*a, dir=None, **kw):
            if dir is not None and not (os.stat(dir).st_mode & 0o222):
                raise PermissionError(13, "Permission denied", str(dir))
            return real_mkdtemp(*a, dir=dir, **kw)
        monkeypatch.setattr("seamfit.output_set.tempfile.mkdtemp", mkdtemp)
    try:
        code, err, secs = run(capsys, *grade_args(PENCIL, ro / "out"))
    finally:
        ro.chmod(0o755)
    assert code == 2 and secs < FAST_S
    one_line_error(err, ro / "out")
