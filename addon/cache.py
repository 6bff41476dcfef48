# SPDX-License-Identifier: GPL-3.0-or-later
"""Precomputation kept between runs, keyed by content hashes of the inputs.

It lives in the add-on's Python state (never in the .blend); seamfit's own disk cache of
distance fields and base drapes is kept in Blender's user folder of the extension, with a
size limit (the extension's preferences). Re-running after a change
of strengths or of the grading method reuses the sewn mesh, the signed distance fields and
the base drape (a grading result is keyed by every input, method included; each piece of
precomputation only by the inputs it depends on);
changing the target body reuses everything that belongs to the base.
"""
from __future__ import annotations

import hashlib
import json
import os
import threading
from collections import OrderedDict
from typing import Any, Callable

import numpy as np

# How many entries each stage keeps (bodies and SDFs are the large ones).
_LIMITS = {"mesh": 4, "body": 6, "sdf": 6, "drape": 4, "grader": 2, "grade": 4, "register": 2}


def digest(*parts: Any) -> str:
    """A stable hash of arrays, strings, numbers and JSON-able containers."""
    h = hashlib.sha1()
    for part in parts:
        if isinstance(part, np.ndarray):
            a = np.ascontiguousarray(part)
            h.update(f"nd{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        elif isinstance(part, (bytes, bytearray)):
            h.update(b"b")
            h.update(part)
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
        h.update(b"|")
    return h.hexdigest()[:20]


class Cache:
    def __init__(self) -> None:
        self._stages: dict[str, OrderedDict[str, Any]] = {k: OrderedDict() for k in _LIMITS}
        self._lock = threading.Lock()
        self.hits: dict[str, int] = {k: 0 for k in _LIMITS}
        self.misses: dict[str, int] = {k: 0 for k in _LIMITS}

    def get(self, stage: str, key: str, make: Callable[[], Any]) -> Any:
        """Return the cached value or compute it with ``make()`` (outside the lock,
        so a long computation does not block the UI reading the cache state)."""
        with self._lock:
            entries = self._stages[stage]
            if key in entries:
                entries.move_to_end(key)
                self.hits[stage] += 1
                return entries[key]
            self.misses[stage] += 1
        value = make()
        with self._lock:
            entries = self._stages[stage]
            entries[key] = value
            entries.move_to_end(key)
            while len(entries) > _LIMITS[stage]:
                entries.popitem(last=False)
        return value

    def peek(self, stage: str, key: str) -> Any:
        with self._lock:
            return self._stages[stage].get(key)

    def has(self, stage: str, key: str) -> bool:
        with self._lock:
            return key in self._stages[stage]

    def counts(self) -> dict[str, int]:
        with self._lock:
            return {k: len(v) for k, v in self._stages.items()}

    def clear(self) -> None:
        with self._lock:
            for v in self._stages.values():
                v.clear()
            for k in self.hits:
                self.hits[k] = self.misses[k] = 0


# The add-on's one cache (cleared when the add-on is disabled).
CACHE = Cache()


# ---------------------------------------------------------------------------
# seamfit's disk cache (body distance fields, base drapes), shared with the command line

CACHE_DIR_ENV = "SEAMFIT_CACHE_DIR"
CACHE_MAX_ENV = "SEAMFIT_CACHE_MAX_MB"
DEFAULT_LIMIT_MB = 2048
_set_by_us: dict = {}


def use_disk_folder(folder: str) -> str:
    """Point seamfit's disk cache at ``folder`` (Blender's user folder of the extension),
    unless $SEAMFIT_CACHE_DIR was set by the user. Returns the folder in use."""
    current = os.environ.get(CACHE_DIR_ENV)
    if current and _set_by_us.get(CACHE_DIR_ENV) != current:
        return current
    os.environ[CACHE_DIR_ENV] = folder
    _set_by_us[CACHE_DIR_ENV] = folder
    return folder


def set_disk_limit(mb: float) -> int:
    """The disk cache's size limit (least recently used entries go first); applies it now.
    Returns the number of entries evicted."""
    os.environ[CACHE_MAX_ENV] = f"{float(mb):g}"
    _set_by_us[CACHE_MAX_ENV] = os.environ[CACHE_MAX_ENV]
    try:
        from seamfit import cache as disk
    except ImportError:
        return 0
    return disk.enforce_limit()


def forget_environment() -> None:
    """Undo what use_disk_folder and set_disk_limit set (when the add-on is disabled)."""
    for key, value in list(_set_by_us.items()):
        if os.environ.get(key) == value:
            del os.environ[key]
        del _set_by_us[key]


def disk_folder() -> str:
    try:
        from seamfit import cache as disk
        return str(disk.cache_root())
    except ImportError:
        return os.environ.get(CACHE_DIR_ENV, "")


def disk_usage() -> tuple[int, int]:
    """(entries, bytes) of seamfit's disk cache."""
    try:
        from seamfit import cache as disk
    except ImportError:
        return 0, 0
    entries = disk.cache_entries()
    return len(entries), sum(size for _, size, _ in entries)


def clear_disk() -> int:
    """Delete every entry of seamfit's disk cache and its in-memory fields; returns how
    many files were removed."""
    try:
        from seamfit import cache as disk
        from seamfit.body import clear_memory_cache
    except ImportError:
        return 0
    clear_memory_cache()
    removed = 0
    for path, _, _ in disk.cache_entries():
        try:
            path.unlink()
            removed += 1
        except OSError:
            pass
    return removed
