"""Triangulate one panel's interior with gmsh, keeping exactly the given boundary vertices.

Each boundary segment is its own gmsh curve meshed transfinite with 2 nodes, so gmsh adds no
point on the boundary; the interior is meshed at the target edge length. gmsh keeps global
state and is not thread-safe: every call holds a lock, runs in a model of its own that it
removes, and finalizes gmsh again if it was the one to initialize it. gmsh is initialized
without its SIGINT handler (``interruptible=False``), which Python only allows on the main
thread; Blender runs solves in a worker thread.
"""
from __future__ import annotations

import itertools
import signal
import threading
from contextlib import contextmanager

import numpy as np

import gmsh

# gmsh 2D algorithms by name; measured on all shared patterns (docs/meshing.md):
# Frontal-Delaunay gives the best minimum angle.
ALGORITHMS = {"meshadapt": 1, "delaunay": 5, "frontal-delaunay": 6}
DEFAULT_ALGORITHM = "frontal-delaunay"
# Laplacian smoothing passes on interior nodes after meshing (gmsh Mesh.Smoothing).
DEFAULT_SMOOTHING = 2

# Boundary vertices next to a segment shorter than SHORT_SEGMENT * h get a local size field
# that grows back to h with this slope (size change per unit distance).
SHORT_SEGMENT = 0.8
SIZE_GRADIENT = 0.2

_lock = threading.RLock()
_model_ids = itertools.count()


class TriangulationError(RuntimeError):
    """gmsh could not mesh a boundary (self-intersecting, degenerate...)."""


@contextmanager
def gmsh_session():
    """Hold gmsh for this thread; initialize (and afterwards finalize) it if nobody else has."""
    with _lock:
        owner = not gmsh.isInitialized()
        if owner:
            with _sigterm_kept():
                gmsh.initialize(readConfigFiles=False, interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setNumber("General.Verbosity", 0)
            yield
        finally:
            if owner:
                gmsh.finalize()


@contextmanager
def _sigterm_kept():
    """gmsh's first initialize in a process resets SIGTERM to the default action (die at once),
    which would skip the CLI's cleanup of temporary outputs; put back the handler Python had."""
    before = signal.getsignal(signal.SIGTERM)
    try:
        yield
    finally:
        if callable(before) and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, before)


def triangulate_polygon(boundary_uv: np.ndarray, edge_length: float, *,
                        algorithm: str = DEFAULT_ALGORITHM, smoothing: int = DEFAULT_SMOOTHING
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the simple polygon ``boundary_uv`` (m, 2), either orientation.

    Returns ``(points, triangles)``: points (N, 2) start with the m boundary vertices unchanged and
    in order, followed by interior vertices; triangles (T, 3) are counter-clockwise in (u, v).
    """
    bnd = np.asarray(boundary_uv, dtype=float)
    m = len(bnd)
    if m < 3:
        raise TriangulationError(f"a boundary needs at least 3 vertices, got {m}")
    if algorithm not in ALGORITHMS:
        raise ValueError(f"unknown gmsh algorithm {algorithm!r}; choose from {sorted(ALGORITHMS)}")
    seg = np.linalg.norm(np.roll(bnd, -1, axis=0) - bnd, axis=1)
    if np.any(seg <= 0):
        raise TriangulationError(f"boundary vertex {int(np.argmin(seg))} repeats the next one")
    # Where the outline forces a segment much shorter than the target (two breakpoints close
    # together), the interior must shrink to match, or gmsh cuts a thin ear off the boundary.
    local = np.minimum(np.minimum(seg, np.roll(seg, 1)), edge_length)
    with gmsh_session():
        name = f"seamfit_panel_{next(_model_ids)}"
        gmsh.model.add(name)
        try:
            return _mesh(bnd, local, edge_length, ALGORITHMS[algorithm], smoothing)
        except Exception as exc:  # gmsh raises bare Exception with its own message
            if isinstance(exc, TriangulationError):
                raise
            raise TriangulationError(str(exc) or type(exc).__name__) from exc
        finally:
            gmsh.model.remove()


def _mesh(bnd: np.ndarray, local: np.ndarray, h: float, algo: int, smoothing: int):
    m = len(bnd)
    geo = gmsh.model.geo
    pts = [geo.addPoint(float(u), float(v), 0.0, h) for u, v in bnd]
    lines = [geo.addLine(pts[i], pts[(i + 1) % m]) for i in range(m)]
    loop = geo.addCurveLoop(lines)
    surf = geo.addPlaneSurface([loop])
    geo.synchronize()
    for ln in lines:
        gmsh.model.mesh.setTransfiniteCurve(ln, 2)
    # Size field: h everywhere, growing from each short boundary segment's length back to h
    # over a distance (h - size) / SIZE_GRADIENT.
    field = gmsh.model.mesh.field
    refine = []
    for k in np.nonzero(local < SHORT_SEGMENT * h)[0]:
        dist = field.add("Distance")
        field.setNumbers(dist, "PointsList", [pts[k]])
        thr = field.add("Threshold")
        field.setNumber(thr, "InField", dist)
        field.setNumber(thr, "SizeMin", float(local[k]))
        field.setNumber(thr, "SizeMax", h)
        field.setNumber(thr, "DistMin", 0.0)
        field.setNumber(thr, "DistMax", float(h - local[k]) / SIZE_GRADIENT)
        refine.append(thr)
    if refine:
        both = field.add("Min")
        field.setNumbers(both, "FieldsList", refine)
        field.setAsBackgroundMesh(both)
    opt = gmsh.option.setNumber
    opt("Mesh.Algorithm", algo)
    opt("Mesh.MeshSizeMax", h)
    opt("Mesh.MeshSizeMin", 0.0)
    opt("Mesh.MeshSizeFromPoints", 1)
    opt("Mesh.MeshSizeExtendFromBoundary", 1)
    opt("Mesh.MeshSizeFromCurvature", 0)
    opt("Mesh.Smoothing", smoothing)
    opt("Mesh.RandomFactor", 1e-9)
    opt("General.NumThreads", 1)
    opt("Mesh.MaxNumThreads2D", 1)
    gmsh.model.mesh.generate(2)

    # gmsh node tag -> our index: boundary point k is vertex k
    tag_to_idx: dict[int, int] = {}
    for k, pt in enumerate(pts):
        tags, _, _ = gmsh.model.mesh.getNodes(0, pt)
        if len(tags) != 1:
            raise TriangulationError(f"boundary vertex {k} got {len(tags)} mesh nodes")
        tag_to_idx[int(tags[0])] = k
    for ln in lines:
        tags, _, _ = gmsh.model.mesh.getNodes(1, ln, includeBoundary=False)
        if len(tags):
            raise TriangulationError("gmsh added vertices on the boundary")
    itags, icoords, _ = gmsh.model.mesh.getNodes(2, surf, includeBoundary=False)
    inner = np.asarray(icoords, dtype=float).reshape(-1, 3)[:, :2]
    for j, t in enumerate(itags):
        tag_to_idx[int(t)] = m + j
    etypes, _, enodes = gmsh.model.mesh.getElements(2, surf)
    tri_nodes = None
    for et, en in zip(etypes, enodes):
        if et == 2:                             # 3-node triangle
            tri_nodes = np.asarray(en, dtype=np.int64).reshape(-1, 3)
        else:
            raise TriangulationError(f"gmsh produced elements of type {et}, expected triangles")
    if tri_nodes is None or len(tri_nodes) == 0:
        raise TriangulationError("gmsh produced no triangles")
    lut = np.vectorize(tag_to_idx.__getitem__, otypes=[np.int64])
    tris = lut(tri_nodes)
    points = np.vstack([bnd, inner])
    # counter-clockwise in (u, v)
    a, b, c = points[tris[:, 0]], points[tris[:, 1]], points[tris[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = cross < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return points, tris.astype(np.int32)

