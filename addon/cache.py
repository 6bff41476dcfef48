# SPDX-License-Identifier: GPL-3.0-or-later
"""Precomputation kept between runs, keyed by content hashes of the inputs.

It lives in the add-on's Python state (never in the .blend): re-running after a change
of strengths or of the grading method reuses the sewn mesh, the signed distance fields and
the base drape (a grading result is keyed by every input, method included; each piece of
precomputation only by the inputs it depends on);
changing the target body reuses everything that belongs to the base.
"""
from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from typing import Any, Callable

import numpy as np

# How many entries each stage keeps (bodies and SDFs are the large ones).
_LIMITS = {"mesh": 4, "body": 6, "sdf": 6, "drape": 4, "grader": 2, "grade": 4}


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
