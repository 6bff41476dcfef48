"""The disk cache checks what it loads: a bad entry (NaN drape, SDF whose grid does not
match its values, NaN field, another key's entry, a truncated file, an entry without its
key) is deleted, reported on stderr and rebuilt, and the run's result equals a clean
run's. Temporaries of dead writers are removed, the size limit evicts the least recently
used entries, and the native queries refuse non-finite input instead of crashing."""
from __future__ import annotations

import logging
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from seamfit import cache
from seamfit._native import core
from seamfit.body import SignedDistanceField, build_sdf, load_body
from seamfit.body import sdf as sdf_mod
from seamfit.errors import BodyError
from seamfit.mesh import build_sewn_mesh
from seamfit.opt.prepare import base_drape
from seamfit.opt.transfer import transfer_garment
from seamfit.pattern import load_pattern
from seamfit.sim.model import Fabric, SimSettings
from common import SAMPLES

PATTERN = SAMPLES / "patterns/gc_pencil_skirt/size06/pattern.json"
B0, B1 = SAMPLES / "bodies/women_size06.obj", SAMPLES / "bodies/women_size10.obj"
H = 0.01  # coarse fields: these tests are about the cache, not accuracy


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(root))
    monkeypatch.delenv("SEAMFIT_CACHE_MAX_MB", raising=False)
    sdf_mod.clear_memory_cache()
    yield root
    sdf_mod.clear_memory_cache()


@pytest.fixture(scope="module")
def body():
    return load_body(B0)


def rewrite(path: Path, change) -> None:
    """Replace the entry at path by change(arrays) (a dict), written as a plain .npz."""
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    change(arrays)
    path.unlink()
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def rejected(caplog, path: Path) -> list:
    return [r.getMessage() for r in caplog.records
            if r.name == "seamfit.cache" and r.levelno == logging.WARNING and str(path) in r.getMessage()]


# ----------------------------------------------------------------------------- SDFs

def _nan_field(z):
    z["values"][3, 4, 5] = np.nan


def _wrong_dims(z):
    nz, ny, nx = z["values"].shape
    z["values"] = np.ascontiguousarray(z["values"]).reshape(nz, nx, ny)  # same count, other grid


def _shifted_origin(z):
    z["origin"] = z["origin"] + 0.01


def _float64_values(z):
    z["values"] = z["values"].astype(np.float64)


SDF_CORRUPTIONS = {"nan field": _nan_field, "mismatched dims": _wrong_dims, "shifted origin": _shifted_origin,
                   "float64 values": _float64_values}


@pytest.mark.parametrize("kind", [*SDF_CORRUPTIONS, "another key's entry", "truncated file"])
def test_bad_sdf_entry_is_rejected_rebuilt_and_reported(kind, cache_dir, body, caplog):
    clean = build_sdf(body, spacing=H)
    entry = cache_dir / "sdf" / f"{clean.info['cache_key']}.npz"
    assert entry.is_file()
    if kind == "another key's entry":
        other = build_sdf(body, spacing=H * 1.2)
        entry.write_bytes((cache_dir / "sdf" / f"{other.info['cache_key']}.npz").read_bytes())
    elif kind == "truncated file":
        truncate(entry)
    else:
        rewrite(entry, SDF_CORRUPTIONS[kind])
    sdf_mod.clear_memory_cache()
    again = build_sdf(body, spacing=H)
    assert again.source == "built", kind
    assert np.array_equal(again.values, clean.values) and np.array_equal(again.origin, clean.origin)
    assert len(rejected(caplog, entry)) == 1, caplog.text
    assert [str(entry) in r for r in again.info["cache_rejected"]] == [True]
    # the entry was rebuilt: the next run reads it, and the report is not stored with it
    sdf_mod.clear_memory_cache()
    warm = build_sdf(body, spacing=H)
    assert warm.source == "disk cache" and np.array_equal(warm.values, clean.values)
    assert "cache_rejected" not in warm.info


def test_sdf_file_with_nan_values_is_refused(tmp_path, body):
    path = build_sdf(body, spacing=H, cache=False).save(tmp_path / "f.npz")
    rewrite(path, _nan_field)
    with pytest.raises(BodyError, match="NaN"):
        SignedDistanceField.load(path)


def test_warning_is_one_line_on_stderr(cache_dir, body):
    """Without any logging set up (the command line), the report is one line on stderr."""
    clean = build_sdf(body, spacing=H)
    entry = cache_dir / "sdf" / f"{clean.info['cache_key']}.npz"
    rewrite(entry, _nan_field)
    script = (f"from seamfit.body import build_sdf, load_body\n"
              f"assert build_sdf(load_body({str(B0)!r}), spacing={H}).source == 'built'\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and str(entry) in lines[0] and "NaN" in lines[0], out.stderr


# ----------------------------------------------------------------------------- base drapes

@pytest.fixture(scope="module")
def drape_case(body):
    pattern = load_pattern(PATTERN)
    mesh = build_sewn_mesh(pattern, edge_length_cm=6.0)
    sdf = build_sdf(body, spacing=0.005, cache=False)
    return mesh, pattern, body, sdf


def drape(case):
    mesh, pattern, body, sdf = case
    return base_drape(mesh, pattern, body, sdf, Fabric(), SimSettings())


def _nan_drape(z):
    z["x"][7] = np.nan


def _fewer_vertices(z):
    z["x"] = z["x"][:-1]


def _other_key(z):
    z[cache.STORED_KEY] = np.array("0" * 32)


def _no_key(z):
    del z[cache.STORED_KEY]


def _inf_residual(z):
    z["residual"] = np.array(np.inf)


DRAPE_CORRUPTIONS = {"nan drape": _nan_drape, "fewer vertices": _fewer_vertices, "wrong stored key": _other_key,
                     "no stored key": _no_key, "infinite residual": _inf_residual}


@pytest.mark.parametrize("kind", [*DRAPE_CORRUPTIONS, "truncated file"])
def test_bad_drape_entry_is_rejected_rebuilt_and_reported(kind, cache_dir, drape_case, caplog):
    x_clean, info = drape(drape_case)
    assert not info["cached"]
    entry = cache_dir / "drape" / f"{info['key']}.npz"
    assert entry.is_file()
    if kind == "truncated file":
        truncate(entry)
    else:
        rewrite(entry, DRAPE_CORRUPTIONS[kind])
    x, info = drape(drape_case)
    assert not info["cached"], kind
    assert np.array_equal(x, x_clean)
    assert len(rejected(caplog, entry)) == 1, caplog.text
    x_warm, info = drape(drape_case)
    assert info["cached"] and np.array_equal(x_warm, x_clean)


def test_grade_from_a_poisoned_cache_equals_a_clean_grade(cache_dir, caplog):
    """The reported cases end to end: a NaN base drape (it crashed in transfer_query) and
    base fields whose values do not fit their grid (the objective went to 8.6e6)."""
    from seamfit.opt.grade import GradeSettings, grade

    settings = GradeSettings(edge_length_cm=6.0, sdf_spacing=H, evaluate_base_pattern=False,
                             max_outer_iterations=2, checkpoint_every=1)

    def run():
        return grade(load_pattern(PATTERN), load_body(B0), load_body(B1), settings)

    clean = run()
    drapes = list((cache_dir / "drape").glob("*.npz"))
    fields = list((cache_dir / "sdf").glob("*.npz"))
    assert len(drapes) == 1 and len(fields) == 2
    rewrite(drapes[0], _nan_drape)
    for f in fields:
        rewrite(f, _wrong_dims)
    sdf_mod.clear_memory_cache()
    again = run()
    assert again.report["base_drape"]["cached"] is False
    assert again.report["objective_final"] == clean.report["objective_final"]
    for a, b in zip(again.pattern.panels, clean.pattern.panels):
        assert np.array_equal(a.outline_cm, b.outline_cm)
    assert all(len(rejected(caplog, p)) == 1 for p in drapes + fields), caplog.text


# ----------------------------------------------------------------------------- temporaries

def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_temporaries_of_dead_writers_are_removed(cache_dir, body):
    folder = cache_dir / "drape"
    folder.mkdir(parents=True)
    old = time.time() - 2 * cache.DEAD_TEMP_AGE_S
    dead = folder / f".{'a' * 32}.npz.pid{_dead_pid()}.0123abcd.tmp"
    stale = folder / f".{'b' * 32}.npz.x8y9z0.tmp"          # an older seamfit's, hours old
    live = folder / f".{'c' * 32}.npz.pid{os.getppid()}.0123abcd.tmp"  # a writer still running
    fresh = folder / f".{'d' * 32}.npz.k2j3h4.tmp"           # being written right now
    for p in (dead, stale, live, fresh):
        p.write_bytes(b"partial")
    for p in (dead, live):
        os.utime(p, (old, old))
    os.utime(stale, (time.time() - 2 * cache.STALE_TEMP_AGE_S,) * 2)
    assert cache.load_arrays("drape", "e" * 32) is None  # any use of the folder sweeps it
    assert sorted(p.name for p in folder.iterdir()) == sorted([live.name, fresh.name])
    # SDF folders too
    sdf_dir = sdf_mod.sdf_cache_dir()
    sdf_dir.mkdir(parents=True, exist_ok=True)
    dead2 = sdf_dir / f".{'f' * 40}.npz.pid{_dead_pid()}.0123abcd.tmp"
    dead2.write_bytes(b"partial")
    os.utime(dead2, (old, old))
    build_sdf(body, spacing=H)
    assert not dead2.exists()


def test_an_interrupted_or_failed_write_leaves_no_temporary(cache_dir):
    path = cache.entry_path("drape", "a" * 32)

    def interrupted(f):
        f.write(b"x" * 1000)
        raise KeyboardInterrupt

    def failing(f):
        f.write(b"x" * 1000)
        raise OSError(28, "No space left on device")

    with pytest.raises(KeyboardInterrupt):
        cache.write_entry(path, interrupted)
    assert cache.write_entry(path, failing) is None
    assert list(path.parent.iterdir()) == []


# ----------------------------------------------------------------------------- size limit

def drape_arrays(n: int) -> dict:
    return {"x": np.zeros((n, 3)), "residual": np.float64(0), "seconds": np.float64(0)}


def _save(key: str, kb: int, mtime: float):
    p = cache.save_arrays("drape", key, drape_arrays(kb * 1024 // 24))
    os.utime(p, (mtime, mtime))
    return p


def test_size_limit_evicts_least_recently_used(cache_dir, monkeypatch, body):
    monkeypatch.setenv("SEAMFIT_CACHE_MAX_MB", str(100 / 1024))  # 100 KB
    t = time.time() - 1000
    a, b, c = (_save(k * 32, 30, t + i) for i, k in enumerate("abc"))
    assert cache.load_arrays("drape", "a" * 32) is not None  # a is now the most recently used
    d = _save("d" * 32, 30, time.time())                      # 120 KB: the oldest, b, goes
    assert a.exists() and not b.exists() and c.exists() and d.exists()
    # an entry larger than the whole limit is not written at all
    assert cache.save_arrays("drape", "f" * 32, drape_arrays(10_000)) is None
    assert sorted(p.name[0] for p in (cache_dir / "drape").iterdir()) == ["a", "c", "d"]
    # SDFs count too (they sit at the cache root when SEAMFIT_CACHE_DIR is set)
    monkeypatch.setenv("SEAMFIT_CACHE_MAX_MB", "4")
    sdf = build_sdf(body, spacing=0.02)
    assert (cache_dir / "sdf" / f"{sdf.info['cache_key']}.npz").exists()
    size = sum(p.stat().st_size for p in cache_dir.rglob("*.npz"))
    monkeypatch.setenv("SEAMFIT_CACHE_MAX_MB", str((size - 1) / 2**20))
    assert cache.enforce_limit() >= 1
    assert sum(p.stat().st_size for p in cache_dir.rglob("*.npz")) <= size - 1


def test_size_limit_setting(monkeypatch, caplog):
    monkeypatch.delenv("SEAMFIT_CACHE_MAX_MB", raising=False)
    assert cache.max_bytes() == 2048 * 2**20
    monkeypatch.setenv("SEAMFIT_CACHE_MAX_MB", "0.5")
    assert cache.max_bytes() == 2**19
    for bad in ("lots", "-1", "nan"):
        monkeypatch.setenv("SEAMFIT_CACHE_MAX_MB", bad)
        assert cache.max_bytes() == 2048 * 2**20
        assert "SEAMFIT_CACHE_MAX_MB" in caplog.text


# ----------------------------------------------------------------------------- native guards

def test_native_queries_refuse_non_finite_input(body):
    V, F = body.vertices, body.faces
    pts = V[:5] + 0.01
    pts[2, 1] = np.nan
    with pytest.raises(ValueError, match="points: row 2"):
        core().transfer_query(V, F, pts, 0.02)
    with pytest.raises(BodyError, match="row 2"):
        transfer_garment(pts, body, body)
    sdf = build_sdf(body, spacing=0.02, cache=False)
    with pytest.raises(ValueError, match="points: row 2"):
        sdf.sample(pts)
    with pytest.raises(ValueError, match="points: row 2"):
        core().sdf_sample_grid(sdf.values, sdf.origin, sdf.spacing, pts)
    bad = sdf.values.copy()
    bad[:] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        core().sdf_sample_grid(bad, sdf.origin, sdf.spacing, V[:3])


def test_a_field_written_behind_is_on_disk_when_read_or_waited_for(tmp_path, monkeypatch):
    """A grading's body fields go to the disk cache on a thread of their own
    (``build_sdf(write_behind=True)``): reading the entry, ``wait_for_writes`` and the
    interpreter's exit wait for it, and it is the same field."""
    import seamfit.body.sdf as sdf_mod
    from seamfit import cache as disk_cache
    from seamfit.body import build_sdf, load_body
    monkeypatch.setenv("SEAMFIT_CACHE_DIR", str(tmp_path / "cache"))
    sdf_mod._memory.clear()
    body = load_body(SAMPLES / "bodies/women_size06.obj")
    release = threading.Event()
    real = disk_cache.write_entry

    def slow(path, write):
        release.wait(timeout=30)
        return real(path, write)

    monkeypatch.setattr(disk_cache, "write_entry", slow)
    built = build_sdf(body, spacing=0.02, write_behind=True)
    path = sdf_mod.sdf_cache_dir() / f"{built.info['cache_key']}.npz"
    assert not path.exists()                      # still being written
    sdf_mod._memory.clear()
    threading.Timer(0.2, release.set).start()
    again = build_sdf(body, spacing=0.02)         # waits for the writer, then reads it
    assert again.source == "disk cache" and np.array_equal(again.values, built.values)
    built2 = build_sdf(body, spacing=0.025, write_behind=True)
    disk_cache.wait_for_writes()
    assert (sdf_mod.sdf_cache_dir() / f"{built2.info['cache_key']}.npz").is_file()
    assert not disk_cache._pending
