"""Read the arrays the optimizer needs from a sewn mesh (``seamfit.mesh.SewnMesh`` or
any object with the same field names), converting the pattern from cm to metres."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PatternError


@dataclass(frozen=True)
class MeshArrays:
    triangles: np.ndarray     # (T, 3) int32
    pbar: np.ndarray          # (N, 2) base pattern, metres
    boundary: np.ndarray      # (N,) bool
    corner: np.ndarray        # (N,) bool
    loops: list               # closed boundary outlines, vertex ids in outline order

    @property
    def n_vertices(self) -> int:
        return len(self.pbar)


def _as_loops(boundary_loops) -> list:
    """Accept per panel either one outline (a sequence of ids) or several (holes)."""
    loops = []
    for entry in boundary_loops:
        if len(entry) and np.ndim(entry[0]) >= 1:
            loops.extend(np.asarray(e, dtype=np.int64) for e in entry)
        else:
            loops.append(np.asarray(entry, dtype=np.int64))
    return loops


def mesh_arrays(mesh) -> MeshArrays:
    uv = np.asarray(mesh.uv_cm, dtype=float)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise PatternError("mesh.uv_cm must be an (N, 2) array")
    n = len(uv)
    tri = np.ascontiguousarray(mesh.triangles, dtype=np.int32)
    boundary = np.asarray(mesh.boundary, dtype=bool)
    corner = np.asarray(getattr(mesh, "corner", np.zeros(n, bool)), dtype=bool)
    if boundary.shape != (n,) or corner.shape != (n,):
        raise PatternError("mesh.boundary and mesh.corner need one flag per vertex")
    loops = _as_loops(mesh.boundary_loops)
    on_loop = np.zeros(n, bool)
    for lp in loops:
        on_loop[lp] = True
    if not np.array_equal(on_loop, boundary):
        bad = np.flatnonzero(on_loop != boundary)
        raise PatternError(f"mesh.boundary_loops and mesh.boundary disagree at {len(bad)} vertices "
                           f"(first: vertex {int(bad[0])})")
    return MeshArrays(tri, np.ascontiguousarray(uv / 100.0), boundary, corner, loops)
