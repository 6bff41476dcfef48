"""A small on-disk cache of arrays keyed by content hashes (base drapes and the like).

Lives under $SEAMFIT_CACHE_DIR (default ~/.cache/seamfit)/<kind>/<key>.npz; entries are
written atomically and a corrupt entry is ignored and rebuilt.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
from pathlib import Path

import numpy as np

from .fileio import atomic_write_bytes


def cache_root() -> Path:
    env = os.environ.get("SEAMFIT_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "seamfit"


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


def load_arrays(kind: str, key: str) -> dict | None:
    path = cache_root() / kind / f"{key}.npz"
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception:  # a truncated or foreign file: rebuild it
        return None


def save_arrays(kind: str, key: str, arrays: dict) -> Path | None:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    try:
        return atomic_write_bytes(cache_root() / kind / f"{key}.npz", buf.getvalue())
    except OSError:  # an unwritable cache never fails a run
        return None
