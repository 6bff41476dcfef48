"""Signed distance fields of bodies (metres, negative inside).

``build_sdf`` validates the body (see :mod:`seamfit.body.validate`), builds the
grid in the compiled core (exact narrow band, closest-triangle propagation,
winding-number sign; the GIL is released) and caches the result twice: in
process (a few recent fields) and on disk under ``$SEAMFIT_CACHE_DIR`` (default
``~/.cache/seamfit/sdf``), keyed by a SHA-256 of the vertices, faces, spacing,
padding, bounds and the algorithm version, so any change rebuilds.

``SignedDistanceField.values`` has shape (nz, ny, nx): flat index
``i + nx * (j + ny * k)``, node (i, j, k) at ``origin + spacing * (i, j, k)``,
which is exactly the layout of the simulator's ``SdfGridView``; ``sample`` calls
its ``sdf_sample`` (trilinear value and the exact gradient of the interpolant).
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import time
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

from .._native import core
from ..errors import BodyError
from ..fileio import atomic_write_bytes
from .io import Body
from .validate import check_body

__all__ = ["SignedDistanceField", "build_sdf", "sdf_cache_key", "sdf_cache_dir", "clear_memory_cache"]

FORMAT = "seamfit-sdf-1"
# Bump when the build's output changes: old cache entries then miss.
ALGORITHM_VERSION = 1
DEFAULT_SPACING = 0.0025
DEFAULT_PADDING = 0.05
MAX_NODES = 400_000_000  # ~1.6 GB of float32 values (plus ~2x while building)
_MEMORY_ENTRIES = 4


class SignedDistanceField:
    """Signed distances on a regular grid; ``values`` is float32 (nz, ny, nx)."""

    def __init__(self, values, origin, spacing, info: dict | None = None, source: str = "memory"):
        values = np.ascontiguousarray(values, dtype=np.float32)
        origin = np.asarray(origin, dtype=np.float64).reshape(-1)
        if values.ndim != 3 or min(values.shape) < 2:
            raise BodyError(f"SDF values must be a 3-D grid with at least 2 nodes per axis, got {values.shape}")
        if origin.shape != (3,) or not np.isfinite(origin).all():
            raise BodyError(f"SDF origin must be 3 finite numbers, got {origin}")
        if not (np.isfinite(spacing) and spacing > 0):
            raise BodyError(f"SDF spacing must be positive, got {spacing}")
        self.values = values
        self.origin = origin
        self.spacing = float(spacing)
        self.info = dict(info or {})
        self.source = source  # "built", "memory cache" or "disk cache"

    @property
    def dims(self) -> tuple[int, int, int]:
        """Node counts (nx, ny, nz)."""
        nz, ny, nx = self.values.shape
        return nx, ny, nz

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World positions of the first and last grid nodes."""
        return self.origin.copy(), self.origin + self.spacing * (np.array(self.dims) - 1)

    @property
    def from_cache(self) -> bool:
        return self.source != "built"

    def sample(self, points) -> tuple[np.ndarray, np.ndarray]:
        """phi (n,) and its gradient (n, 3) at points (n, 3): trilinear, with the
        exact gradient of the interpolant; outside the grid phi grows with the
        distance to the box (see sdf_grid.hpp)."""
        pts = np.ascontiguousarray(points, dtype=np.float64)
        if pts.ndim == 1 and pts.shape[0] == 3:
            pts = pts.reshape(1, 3)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {np.shape(points)}")
        return core().sdf_sample_points(self.values, self.dims, tuple(self.origin), self.spacing, pts)

    def save(self, path) -> Path:
        """Write an uncompressed .npz atomically (fast to load)."""
        buf = io.BytesIO()
        np.savez(buf, format=np.array(FORMAT), values=self.values, origin=self.origin,
                 spacing=np.array(self.spacing), info=np.array(json.dumps(_jsonable(self.info))))
        return atomic_write_bytes(Path(path), buf.getvalue())

    @classmethod
    def load(cls, path) -> "SignedDistanceField":
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                if "format" not in z or str(z["format"]) != FORMAT:
                    raise BodyError(f"{path}: not a seamfit SDF file (format {FORMAT!r} expected)")
                values, origin, spacing = z["values"], z["origin"], float(z["spacing"])
                info = json.loads(str(z["info"])) if "info" in z else {}
        except FileNotFoundError:
            raise BodyError(f"{path}: no such SDF file") from None
        except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
            raise BodyError(f"{path}: unreadable SDF file: {exc}") from None
        if values.dtype != np.float32:
            raise BodyError(f"{path}: SDF values must be float32, got {values.dtype}")
        return cls(values, origin, spacing, info=info, source="file")


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


# ----------------------------------------------------------------------------- cache

_memory: "OrderedDict[str, SignedDistanceField]" = OrderedDict()


def clear_memory_cache() -> None:
    _memory.clear()


def sdf_cache_dir() -> Path:
    env = os.environ.get("SEAMFIT_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "seamfit" / "sdf"


def _norm_bounds(bounds):
    if bounds is None:
        return None
    b = np.asarray(bounds, dtype=np.float64).reshape(-1)
    if b.shape == (2 * 3,):
        return tuple(float(x) for x in b)
    if np.asarray(bounds).shape == (2, 3):
        return tuple(float(x) for x in np.asarray(bounds, dtype=np.float64).ravel())
    raise BodyError(f"bounds must be (xmin, ymin, zmin, xmax, ymax, zmax) or [[min], [max]], got {bounds!r}")


def sdf_cache_key(body: Body, spacing: float, padding: float, bounds=None) -> str:
    h = hashlib.sha256()
    h.update(f"{FORMAT}/{ALGORITHM_VERSION}".encode())
    h.update(np.ascontiguousarray(body.vertices, dtype=np.float64).tobytes())
    h.update(b"|faces|")
    h.update(np.ascontiguousarray(body.faces, dtype=np.int32).tobytes())
    h.update(repr((float(spacing), float(padding), _norm_bounds(bounds))).encode())
    return h.hexdigest()[:40]


def _remember(key: str, sdf: SignedDistanceField) -> None:
    _memory[key] = sdf
    _memory.move_to_end(key)
    while len(_memory) > _MEMORY_ENTRIES:
        _memory.popitem(last=False)


def _from_disk(path: Path, key: str):
    if not path.is_file():
        return None
    try:
        sdf = SignedDistanceField.load(path)
    except BodyError:
        return None  # unreadable entry: rebuilt and overwritten
    if sdf.info.get("cache_key") != key:
        return None
    return sdf


# ----------------------------------------------------------------------------- build

def build_sdf(body: Body, spacing: float = DEFAULT_SPACING, padding: float = DEFAULT_PADDING, bounds=None,
              cache: bool = True, threads: int = 0) -> SignedDistanceField:
    """Signed distance field of ``body`` (negative inside) with node spacing
    ``spacing`` over its bounding box plus ``padding`` (metres), or over exactly
    ``bounds`` = (xmin, ymin, zmin, xmax, ymax, zmax). Raises BodyError for an
    unusable body or grid. ``cache`` reuses a field built from identical inputs."""
    if not (np.isfinite(spacing) and spacing > 0):
        raise BodyError(f"{body.where}: spacing must be a positive number of metres, got {spacing}")
    if not (np.isfinite(padding) and padding >= 0):
        raise BodyError(f"{body.where}: padding must be >= 0 metres, got {padding}")
    nb = _norm_bounds(bounds)
    if nb is not None and not (all(np.isfinite(nb)) and all(nb[a + 3] > nb[a] for a in range(3))):
        raise BodyError(f"{body.where}: bounds need finite values with max > min on every axis, got {bounds!r}")
    key = sdf_cache_key(body, spacing, padding, nb)
    if cache:
        hit = _memory.get(key)
        if hit is not None:
            _memory.move_to_end(key)
            return SignedDistanceField(hit.values, hit.origin, hit.spacing, hit.info, source="memory cache")
        disk_path = sdf_cache_dir() / f"{key}.npz"
        hit = _from_disk(disk_path, key)
        if hit is not None:
            hit.values.flags.writeable = False
            _remember(key, hit)
            return SignedDistanceField(hit.values, hit.origin, hit.spacing, hit.info, source="disk cache")

    report = check_body(body)
    t0 = time.perf_counter()
    try:
        values, info = core().sdf_build(body.vertices, report.oriented_faces, spacing=float(spacing),
                                        padding=float(padding), bounds=nb, threads=int(threads),
                                        max_nodes=MAX_NODES)
    except ValueError as exc:
        raise BodyError(f"{body.where}: cannot build the SDF: {exc}") from None
    except MemoryError:
        raise BodyError(f"{body.where}: not enough memory for an SDF with spacing {spacing} m; "
                        f"use a larger spacing or bounds") from None
    info = dict(info)
    info.update(build_seconds=time.perf_counter() - t0, padding=float(padding), bounds=nb,
                body=body.where, n_vertices=body.n_vertices, n_faces=body.n_faces,
                watertight=report.watertight, warnings=list(report.warnings),
                algorithm_version=ALGORITHM_VERSION, cache_key=key)
    values.flags.writeable = False  # shared with the caches
    sdf = SignedDistanceField(values, info["origin"], spacing, info, source="built")
    if cache:
        _remember(key, sdf)
        try:
            sdf.save(sdf_cache_dir() / f"{key}.npz")
        except OSError:
            pass  # a read-only or full cache directory only costs a rebuild next time
    return sdf
