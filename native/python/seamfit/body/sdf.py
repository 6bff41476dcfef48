"""Signed distance fields of bodies (metres, negative inside).

``build_sdf`` validates the body (see :mod:`seamfit.body.validate`), builds the
grid in the compiled core (exact narrow band, closest-triangle propagation,
winding-number sign; the GIL is released) and caches the result twice: in
process (a few recent fields) and on disk under ``$SEAMFIT_CACHE_DIR`` (default
``~/.cache/seamfit/sdf``), keyed by a SHA-256 of the vertices, faces, spacing,
padding, bounds and the algorithm version, so any change rebuilds. A disk entry is
checked before use (its stored key, the grid's shape, origin and spacing against the
requested layout, float32 finite values): a bad one is deleted, reported and rebuilt
(see :mod:`seamfit.cache`). The build is deterministic: the same bits for any thread
count, so a rebuilt field equals the cached one.

``device="cuda"`` computes every node's exact distance to the nearest triangle on the
GPU (a BVH query per node) and the sign on the CPU as above. Those values can lie a
fraction of a millimetre below the CPU's propagated ones at a few nodes away from the
body, so a GPU-built field has a cache key of its own: neither device is served the
other's field.

``SignedDistanceField.values`` has shape (nz, ny, nx): flat index
``i + nx * (j + ny * k)``, node (i, j, k) at ``origin + spacing * (i, j, k)``,
which is exactly the layout of the simulator's ``SdfGridView``; ``sample`` calls
its ``sdf_sample`` (trilinear value and the exact gradient of the interpolant).
"""
from __future__ import annotations

import hashlib
import io
import json
import time
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

from .. import cache as disk_cache
from .._native import core
from ..device import require_device
from ..errors import BodyError
from ..fileio import atomic_write_bytes
from .io import Body
from .validate import check_body

__all__ = ["SignedDistanceField", "build_sdf", "sdf_cache_key", "sdf_cache_dir", "clear_memory_cache"]

FORMAT = "seamfit-sdf-1"
# Bump when the build's output changes: old cache entries then miss.
# 2: propagation made deterministic (the same bits for any thread count).
# 3: propagation sweeps on every thread (an upward pass, then a downward one).
ALGORITHM_VERSION = 3
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
        self._write(buf)
        return atomic_write_bytes(Path(path), buf.getvalue())

    def _write(self, f) -> None:
        np.savez(f, format=np.array(FORMAT), values=self.values, origin=self.origin,
                 spacing=np.array(self.spacing), info=np.array(json.dumps(_jsonable(self.info))))

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
        if not np.isfinite(values).all():
            raise BodyError(f"{path}: SDF values include NaN or infinity")
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
    """``sdf/`` under the cache root, as the other kinds' folders (also with $SEAMFIT_CACHE_DIR)."""
    return disk_cache.cache_root() / "sdf"


def _norm_bounds(bounds):
    if bounds is None:
        return None
    b = np.asarray(bounds, dtype=np.float64).reshape(-1)
    if b.shape == (2 * 3,):
        return tuple(float(x) for x in b)
    if np.asarray(bounds).shape == (2, 3):
        return tuple(float(x) for x in np.asarray(bounds, dtype=np.float64).ravel())
    raise BodyError(f"bounds must be (xmin, ymin, zmin, xmax, ymax, zmax) or [[min], [max]], got {bounds!r}")


# The builders whose fields differ (see build_sdf); the CPU's adds nothing to the key, so
# its keys are those from before the GPU builder existed.
_BUILDER_TAG = {"cpu": None, "cuda": b"|builder:gpu-exact-nearest/1|"}


def sdf_cache_key(body: Body, spacing: float, padding: float, bounds=None, device: str = "cpu") -> str:
    h = hashlib.sha256()
    h.update(f"{FORMAT}/{ALGORITHM_VERSION}".encode())
    h.update(np.ascontiguousarray(body.vertices, dtype=np.float64).tobytes())
    h.update(b"|faces|")
    h.update(np.ascontiguousarray(body.faces, dtype=np.int32).tobytes())
    h.update(repr((float(spacing), float(padding), _norm_bounds(bounds))).encode())
    tag = _BUILDER_TAG[require_device(device, "the SDF build", runnable=False)]
    if tag is not None:
        h.update(tag)
    return h.hexdigest()[:40]


def _remember(key: str, sdf: SignedDistanceField) -> None:
    _memory[key] = sdf
    _memory.move_to_end(key)
    while len(_memory) > _MEMORY_ENTRIES:
        _memory.popitem(last=False)


def _entry_problem(z: dict, key: str, layout: dict, spacing: float) -> str | None:
    """Why a cache entry's arrays cannot serve the request, or None."""
    for name in ("format", "values", "origin", "spacing", "info"):
        if name not in z:
            return f"array {name!r} is missing"
    if z["format"].shape != () or str(z["format"]) != FORMAT:
        return f"not a {FORMAT} file"
    try:
        stored = json.loads(str(z["info"])).get("cache_key")
    except (ValueError, AttributeError):
        return "its info is not a JSON object"
    if stored != key:
        return f"it was stored under another key ({str(stored)[:40]!r})"
    values, origin, sp = z["values"], z["origin"], z["spacing"]
    nx, ny, nz = layout["dims"]
    if values.dtype != np.float32 or values.shape != (nz, ny, nx):
        return f"values are {values.dtype} {values.shape}, expected float32 {(nz, ny, nx)}"
    if origin.shape != (3,) or not np.allclose(origin, layout["origin"], rtol=0, atol=1e-9):
        return f"origin {origin} differs from the grid's {tuple(layout['origin'])}"
    if sp.shape != () or float(sp) != float(spacing):
        return f"spacing {sp} differs from {spacing}"
    if not np.isfinite(values).all():
        return f"{int(values.size - np.isfinite(values).sum())} of {values.size} values are NaN or infinite"
    return None


def _from_disk(path: Path, key: str, body: Body, spacing: float, padding: float, bounds, problems: list):
    try:
        layout = core().sdf_layout(np.ascontiguousarray(body.vertices, dtype=np.float64), float(spacing),
                                   float(padding), bounds)
    except ValueError:
        return None  # an unusable body: the build reports why
    z = disk_cache.read_entry(path, lambda z: _entry_problem(z, key, layout, spacing), problems)
    if z is None:
        return None
    return SignedDistanceField(z["values"], z["origin"], float(z["spacing"]), json.loads(str(z["info"])),
                               source="disk cache")


# ----------------------------------------------------------------------------- build

def _referenced_only(body: Body) -> Body:
    """The body without vertices that no face uses: they are not part of the surface, and
    one stray vertex far away would otherwise stretch the grid's box to it."""
    f = body.faces
    if f.size == 0 or f.min() < 0 or f.max() >= body.n_vertices:
        return body                               # check_body reports it
    used = np.zeros(body.n_vertices, bool)
    used[f.ravel()] = True
    if used.all():
        return body
    new_index = np.cumsum(used) - 1
    return Body(body.vertices[used], new_index[f], name=body.name, source_file=body.source_file,
                meta=dict(body.meta))


def build_sdf(body: Body, spacing: float = DEFAULT_SPACING, padding: float = DEFAULT_PADDING, bounds=None,
              cache: bool = True, threads: int = 0, device: str = "cpu",
              write_behind: bool = False) -> SignedDistanceField:
    """Signed distance field of ``body`` (negative inside) with node spacing
    ``spacing`` over its bounding box plus ``padding`` (metres), or over exactly
    ``bounds`` = (xmin, ymin, zmin, xmax, ymax, zmax). Raises BodyError for an
    unusable body or grid. ``cache`` reuses a field built from identical inputs
    by the same device's builder; ``write_behind`` stores a new one on disk on a thread
    of its own (seamfit.cache.write_entry_soon) instead of before returning. ``device``: "cpu" (band, propagation, sign) or
    "cuda" (exact nearest distances on the GPU, the sign on the CPU); DeviceError
    when cuda cannot run here."""
    require_device(device, "the SDF build")
    if not (np.isfinite(spacing) and spacing > 0):
        raise BodyError(f"{body.where}: spacing must be a positive number of metres, got {spacing}")
    if not (np.isfinite(padding) and padding >= 0):
        raise BodyError(f"{body.where}: padding must be >= 0 metres, got {padding}")
    nb = _norm_bounds(bounds)
    if nb is not None and not (all(np.isfinite(nb)) and all(nb[a + 3] > nb[a] for a in range(3))):
        raise BodyError(f"{body.where}: bounds need finite values with max > min on every axis, got {bounds!r}")
    body = _referenced_only(body)
    key = sdf_cache_key(body, spacing, padding, nb, device)
    rejected: list = []
    if cache:
        hit = _memory.get(key)
        if hit is not None:
            _memory.move_to_end(key)
            return SignedDistanceField(hit.values, hit.origin, hit.spacing, hit.info, source="memory cache")
        disk_path = sdf_cache_dir() / f"{key}.npz"
        hit = _from_disk(disk_path, key, body, spacing, padding, nb, rejected)
        if hit is not None:
            hit.values.flags.writeable = False
            _remember(key, hit)
            return SignedDistanceField(hit.values, hit.origin, hit.spacing, hit.info, source="disk cache")

    report = check_body(body)
    t0 = time.perf_counter()
    try:
        values, info = core().sdf_build(body.vertices, report.oriented_faces, spacing=float(spacing),
                                        padding=float(padding), bounds=nb, threads=int(threads),
                                        max_nodes=MAX_NODES, device=device)
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
        # A read-only or full cache directory only costs a rebuild next time.
        (disk_cache.write_entry_soon if write_behind else disk_cache.write_entry)(
            sdf_cache_dir() / f"{key}.npz", sdf._write)
    if rejected:  # reported on this result only, not stored with the field
        sdf = SignedDistanceField(values, sdf.origin, spacing, {**info, "cache_rejected": rejected}, source="built")
    return sdf
