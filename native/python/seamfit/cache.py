"""A small on-disk cache of arrays keyed by content hashes (body SDFs, base drapes).

Entries live under $SEAMFIT_CACHE_DIR (default ~/.cache/seamfit)/<kind>/<key>.npz. Nothing
read from the cache is trusted: an entry must hold the key it was requested under (stored
inside it), the arrays its kind needs with the right shapes and dtypes, and only finite
numbers. A bad entry (truncated, foreign, renamed, NaN, wrong shape) is deleted, reported
by a one-line warning on stderr (logger "seamfit.cache") and rebuilt by the caller.

Writes go through a temporary file in the entry's folder, named after the writing
process, then an atomic rename; temporaries of processes that died mid-write are removed
the next time the folder is used. The cache is limited to $SEAMFIT_CACHE_MAX_MB megabytes
(default 2048): after each save the least recently used entries are evicted.
"""
from __future__ import annotations

import atexit
import hashlib
import json
import logging
import os
import re
import secrets
import threading
import time
from pathlib import Path
from typing import Callable, Optional

import numpy as np

__all__ = ["cache_entries", "cache_root", "enforce_limit"]

log = logging.getLogger("seamfit.cache")

DEFAULT_MAX_MB = 2048
STORED_KEY = "cache_key"                 # the array holding an entry's own key
_ENTRY_NAME = re.compile(r"^[0-9a-f]{16,64}\.npz$")
_TEMP_NAME = re.compile(r"^\..+\.tmp$")
_OUR_TEMP = re.compile(r"^\..+\.pid(\d+)\.[0-9a-f]+\.tmp$")
DEAD_TEMP_AGE_S = 60.0                   # a dead writer's temporary, once this old
STALE_TEMP_AGE_S = 6 * 3600.0            # any temporary (another host's, an old seamfit's)

# What each kind's entries hold: name -> shape (None: any length on that axis).
SPECS = {
    "drape": {"x": (None, 3), "residual": (), "seconds": ()},
}

_swept: set = set()
_rejected: list = []


def cache_root() -> Path:
    env = os.environ.get("SEAMFIT_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "seamfit"


def entry_path(kind: str, key: str) -> Path:
    return cache_root() / kind / f"{key}.npz"


def content_key(*parts) -> str:
    """sha256 over arrays (bytes, dtype and shape), strings and JSON-able values."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            a = np.ascontiguousarray(part)
            h.update(str((a.dtype.str, a.shape)).encode())
            h.update(a.tobytes())
        elif isinstance(part, (bytes, bytearray)):
            h.update(part)
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
        h.update(b"\x00")
    return h.hexdigest()[:32]


def max_bytes() -> int:
    """The cache's size limit ($SEAMFIT_CACHE_MAX_MB, default 2048 MB; 0 keeps nothing)."""
    raw = os.environ.get("SEAMFIT_CACHE_MAX_MB", "").strip()
    if not raw:
        return DEFAULT_MAX_MB * 2**20
    try:
        mb = float(raw)
    except ValueError:
        mb = float("nan")
    if not (np.isfinite(mb) and mb >= 0):
        log.warning("seamfit: warning: SEAMFIT_CACHE_MAX_MB=%r is not a size in MB; using %d",
                    raw, DEFAULT_MAX_MB)
        return DEFAULT_MAX_MB * 2**20
    return int(mb * 2**20)


def rejected_entries() -> list:
    """(path, reason) of every cache entry this process found bad and deleted."""
    return list(_rejected)


# ----------------------------------------------------------------------------- reading

def check_arrays(arrays: dict, key: str, spec: Optional[dict] = None) -> Optional[str]:
    """Why ``arrays`` (an entry's contents) cannot serve ``key``, or None when they can."""
    stored = arrays.get(STORED_KEY)
    if stored is None:
        return "it does not record its key (written by an older seamfit?)"
    if stored.shape != () or str(stored) != key:
        return f"it was stored under another key ({str(stored)[:40]!r})"
    for name, shape in (spec or {}).items():
        if name not in arrays:
            return f"array {name!r} is missing"
        a = arrays[name]
        if len(a.shape) != len(shape) or any(w is not None and w != n for w, n in zip(shape, a.shape)):
            want = "(" + ", ".join("n" if w is None else str(w) for w in shape) + ("," if len(shape) == 1 else "") + ")"
            return f"array {name!r} has shape {a.shape}, expected {want}"
    for name, a in arrays.items():
        if name == STORED_KEY:
            continue
        if a.dtype.kind not in "fiub":
            return f"array {name!r} has dtype {a.dtype}, expected numbers"
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            return f"array {name!r} has {int(a.size - np.isfinite(a).sum())} of {a.size} values NaN or infinite"
    return None


def read_entry(path: Path, check: Callable[[dict], Optional[str]], problems: Optional[list] = None) -> Optional[dict]:
    """The arrays of the entry at ``path`` if it exists and ``check`` (returning a reason
    or None) accepts them; a bad entry is deleted and reported (and its reason appended
    to ``problems``), and None returned."""
    path = Path(path)
    wait_for_writes(path)
    sweep_temporaries(path.parent)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as exc:  # truncated, not a zip, pickled objects, I/O error
        problem = f"it is unreadable ({type(exc).__name__}: {exc})"
    else:
        try:
            problem = check(arrays)
        except Exception as exc:  # arrays of unexpected types that the check cannot compare
            problem = f"it is malformed ({type(exc).__name__}: {exc})"
    if problem is not None:
        reject(path, problem)
        if problems is not None:
            problems.append(f"{path}: {problem}")
        return None
    try:
        os.utime(path)  # recently used: evicted last
    except OSError:
        pass
    return arrays


def reject(path: Path, problem: str) -> None:
    try:
        path.unlink()
    except FileNotFoundError:
        pass
    except OSError as exc:
        problem += f"; it could not be deleted ({exc})"
    _rejected.append((str(path), problem))
    log.warning("seamfit: warning: discarded cache entry %s: %s; rebuilding it", path, problem)


def load_arrays(kind: str, key: str, expect: Optional[dict] = None) -> Optional[dict]:
    """The arrays saved under (kind, key), checked (stored key, the kind's arrays and
    ``expect``'s exact shapes, finite values), or None when absent or bad."""
    spec = dict(SPECS.get(kind, {}))
    spec.update({name: tuple(shape) for name, shape in (expect or {}).items()})
    arrays = read_entry(entry_path(kind, key), lambda a: check_arrays(a, key, spec))
    if arrays is None:
        return None
    arrays.pop(STORED_KEY, None)
    return arrays


# ----------------------------------------------------------------------------- writing

def save_arrays(kind: str, key: str, arrays: dict) -> Optional[Path]:
    if STORED_KEY in arrays:
        raise ValueError(f"{STORED_KEY!r} is reserved")
    return write_entry(entry_path(kind, key), lambda f: np.savez(f, **{STORED_KEY: np.array(key)}, **arrays))


_pending: dict = {}                 # path -> the thread writing it (write_entry_soon)
_pending_lock = threading.Lock()


def write_entry_soon(path: Path, write: Callable) -> None:
    """``write_entry`` on a thread of its own, for an entry the run does not wait for (a body
    field: 250 MB, written while the grading goes on). ``wait_for_writes`` waits for it;
    reading that entry, and the interpreter's exit, do so too."""
    path = Path(path)
    wait_for_writes(path)               # one writer per entry

    def run():
        try:
            write_entry(path, write)
        except Exception:   # noqa: BLE001 - a cache never fails a run: the next one rebuilds
            pass

    t = threading.Thread(target=run, name="seamfit-cache-write", daemon=True)
    with _pending_lock:
        _pending[path] = t
    t.start()


@atexit.register
def wait_for_writes(path: Optional[Path] = None) -> None:
    """Wait until the entries written by ``write_entry_soon`` (only ``path``'s, if given) are
    on disk."""
    with _pending_lock:
        todo = [(p, t) for p, t in _pending.items() if path is None or p == Path(path)]
    for p, t in todo:
        t.join()
        with _pending_lock:
            if _pending.get(p) is t:
                del _pending[p]


def write_entry(path: Path, write: Callable) -> Optional[Path]:
    """Write an entry with ``write(file)`` atomically, then hold the cache to its size limit.
    Returns None (and leaves nothing behind) when the cache cannot be written or the entry
    alone exceeds the limit: a cache never fails a run."""
    path = Path(path)
    tmp = path.parent / f".{path.name}.pid{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        sweep_temporaries(path.parent)
        # No fsync: an entry cut short by a crash fails its check and is rebuilt.
        with open(tmp, "xb") as f:
            write(f)
        size = tmp.stat().st_size
        if size > max_bytes():
            tmp.unlink()
            return None
        os.replace(tmp, path)
    except OSError:
        _remove_quietly(tmp)
        return None
    except BaseException:  # interrupted: leave no temporary behind
        _remove_quietly(tmp)
        raise
    enforce_limit(keep=path)
    return path


def _remove_quietly(p: Path) -> None:
    try:
        p.unlink()
    except OSError:
        pass


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, another user's
        return True
    return True


def sweep_temporaries(folder: Path, force: bool = False) -> int:
    """Remove temporaries left in ``folder`` by writers that died (once per process and
    folder unless ``force``). Returns how many were removed."""
    folder = Path(folder)
    if not force and folder in _swept:
        return 0
    _swept.add(folder)
    removed, now = 0, time.time()
    try:
        names = [e for e in os.scandir(folder) if _TEMP_NAME.match(e.name) and e.is_file(follow_symlinks=False)]
    except OSError:
        return 0
    for e in names:
        try:
            age = now - e.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        m = _OUR_TEMP.match(e.name)
        pid = int(m.group(1)) if m else None
        dead = pid is not None and pid != os.getpid() and not _pid_alive(pid)
        if (dead and age > DEAD_TEMP_AGE_S) or age > STALE_TEMP_AGE_S:
            try:
                os.unlink(e.path)
                removed += 1
            except OSError:
                pass
    return removed


def cache_entries() -> list:
    """(path, size, mtime) of every entry: <root>/*.npz and <root>/<kind>/*.npz with hex names."""
    root = cache_root()
    out = []
    for folder in [root] + ([d for d in root.iterdir() if d.is_dir()] if root.is_dir() else []):
        try:
            for e in os.scandir(folder):
                if _ENTRY_NAME.match(e.name) and e.is_file(follow_symlinks=False):
                    st = e.stat(follow_symlinks=False)
                    out.append((Path(e.path), st.st_size, st.st_mtime))
        except OSError:
            continue
    return out


def enforce_limit(keep: Optional[Path] = None, limit: Optional[int] = None) -> int:
    """Evict least recently used entries (oldest modification time; reads touch it) until
    the cache fits its limit; ``keep`` (the entry just written) goes last. Returns the
    number of entries removed."""
    limit = max_bytes() if limit is None else limit
    entries = cache_entries()
    total = sum(size for _, size, _ in entries)
    if total <= limit:
        return 0
    entries.sort(key=lambda e: (keep is not None and e[0] == keep, e[2]))
    removed = 0
    for p, size, _ in entries:
        if total <= limit:
            break
        try:
            p.unlink()
        except FileNotFoundError:
            pass
        except OSError:
            continue
        total -= size
        removed += 1
    return removed
