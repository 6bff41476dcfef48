"""The sewn-ready mesh: every panel triangulated, all in one vertex array, with sewing pairs.

Vertices are numbered panel by panel; within a panel the boundary loop comes first, in outline
order, then the interior vertices. Panels never share a vertex: a seam is a set of sewing pairs
(the sewing springs of Wang 2018, section 4) between boundary vertices.

Shared end points. Consecutive stitches on one panel share their end vertex (a corner where two
seams meet), and the pair formed there is usually formed by both stitches (the side seam and the
waistband seam both join the same two corners); such a pair is kept once and belongs to the
lower-numbered stitch. A pair of a vertex with itself (the tip of a dart, where both dart legs
meet) is dropped. A vertex can still be in several pairs (four panels meeting at one point),
which is what the cloth needs there.
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import PatternError
from ..pattern.model import Pattern
from .boundary import DEFAULT_EDGE_LENGTH_CM, PatternBoundary, sample_boundary
from .quality import SHARP_CORNER_DEG, inside_angles_deg, min_angles, signed_areas
from .triangulate import DEFAULT_ALGORITHM, TriangulationError, gmsh_session, triangulate_polygon

# Bump when anything changes what build_sewn_mesh produces for the same input.
MESH_VERSION = 1


@dataclass
class OutlineMap:
    """Where each original outline point of a panel sits relative to the boundary loop.

    Outline point i = uv[a] + t * (uv[b] - uv[a]) + w * perp(uv[b] - uv[a]), perp(x, y) = (-y, x),
    with a, b consecutive boundary vertices (global ids). Points that are vertices have a == their
    vertex, t = w = 0. The normal offset w keeps the outline's detail between two boundary vertices
    and moves it with their chord.
    """
    a: np.ndarray        # (n,) int
    b: np.ndarray        # (n,) int
    t: np.ndarray        # (n,) along the chord, in chord lengths
    w: np.ndarray        # (n,) across the chord (left of a -> b), in chord lengths
    vertex: np.ndarray   # (n,) the vertex the outline point is, -1 if it lies between two


@dataclass
class StitchInfo:
    kind: str
    panel_a: str
    range_a: tuple[int, int]
    panel_b: str
    range_b: tuple[int, int]
    orientation: str
    gathered: bool


@dataclass
class SewnMesh:
    panel_names: list[str]
    uv_cm: np.ndarray               # (N, 2) pattern coordinates, cm
    x0: np.ndarray                  # (N, 3) start positions from the panel placements, m
    triangles: np.ndarray           # (T, 3) int32, winding gives each panel's outward normal in 3D
    triangle_panel: np.ndarray      # (T,) int32
    vertex_panel: np.ndarray        # (N,) int32
    boundary: np.ndarray            # (N,) bool
    corner: np.ndarray              # (N,) bool, the pattern's corners
    sewing_pairs: np.ndarray        # (K, 2) int32, unique, no vertex paired with itself
    pair_stitch: np.ndarray         # (K,) int32, the stitch a pair belongs to
    boundary_loops: list[np.ndarray]            # per panel, vertex ids in outline order
    landmark_vertex: dict[tuple[str, str], int]  # (panel, landmark) -> vertex
    outline_maps: list[OutlineMap]               # per panel
    stitch_pairs: list[np.ndarray]  # per stitch, all (k, 2) pairs side a -> side b in a's order
    stitches: list[StitchInfo]
    outward_normals: np.ndarray     # (P, 3) each panel's outward normal in the world
    outline_area_cm2: np.ndarray    # (P,) area of each original outline
    edge_length_cm: float
    source_file: str | None = None
    garment_id: str | None = None
    body_id: str | None = None
    build_seconds: float = 0.0
    _stats: dict | None = field(default=None, repr=False)

    @property
    def n_vertices(self) -> int:
        return len(self.uv_cm)

    def panel_vertices(self, panel: int | str) -> np.ndarray:
        k = self.panel_names.index(panel) if isinstance(panel, str) else int(panel)
        return np.nonzero(self.vertex_panel == k)[0]

    def panel_triangles(self, panel: int | str) -> np.ndarray:
        k = self.panel_names.index(panel) if isinstance(panel, str) else int(panel)
        return self.triangles[self.triangle_panel == k]

    def sharp_vertices(self, threshold_deg: float = SHARP_CORNER_DEG) -> np.ndarray:
        """Boundary vertices whose inside angle in the flat panel is below threshold_deg."""
        out = []
        for loop in self.boundary_loops:
            out.append(loop[inside_angles_deg(self.uv_cm[loop]) < threshold_deg])
        return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)

    def seam_count_mismatch(self) -> list[int]:
        """Per stitch: boundary vertices in range a minus those in range b, counted on the loops."""
        out = []
        for st in self.stitches:
            counts = []
            for name, rng in ((st.panel_a, st.range_a), (st.panel_b, st.range_b)):
                k = self.panel_names.index(name)
                counts.append(len(loop_vertices_in_range(self, k, rng)))
            out.append(counts[0] - counts[1])
        return out

    def stats(self) -> dict:
        """Sizes and quality: counts, minimum angles (all and away from sharp corners), area errors."""
        if self._stats is None:
            sharp = self.sharp_vertices()
            overall, interior = min_angles(self.uv_cm, self.triangles, sharp)
            area = signed_areas(self.uv_cm, self.triangles)
            errs = {}
            for k, name in enumerate(self.panel_names):
                a = float(np.sum(np.abs(area[self.triangle_panel == k])))
                errs[name] = abs(a - self.outline_area_cm2[k]) / self.outline_area_cm2[k]
            mismatch = self.seam_count_mismatch()
            self._stats = {
                "panels": len(self.panel_names),
                "vertices": int(self.n_vertices),
                "boundary_vertices": int(self.boundary.sum()),
                "triangles": int(len(self.triangles)),
                "stitches": len(self.stitches),
                "sewing_pairs": int(len(self.sewing_pairs)),
                "edge_length_cm": self.edge_length_cm,
                "min_angle_deg": overall,
                "min_angle_interior_deg": interior,
                "sharp_corners": int(len(sharp)),
                "area_error": errs,
                "max_area_error": max(errs.values()) if errs else 0.0,
                "max_seam_count_mismatch": int(max((abs(m) for m in mismatch), default=0)),
                "seconds": self.build_seconds,
            }
        return dict(self._stats)

    def cache_key(self) -> str:
        """SHA-256 of everything that defines the mesh; equal keys mean interchangeable meshes."""
        hsh = hashlib.sha256()
        hsh.update(f"seamfit-mesh-{MESH_VERSION}|{self.edge_length_cm!r}|".encode())
        hsh.update("\x00".join(self.panel_names).encode())
        for arr in (self.uv_cm, self.x0, self.triangles, self.triangle_panel, self.sewing_pairs,
                    self.pair_stitch):
            a = np.ascontiguousarray(arr)
            hsh.update(f"|{a.dtype.str}{a.shape}|".encode())
            hsh.update(a.tobytes())
        return hsh.hexdigest()


def loop_vertices_in_range(mesh: SewnMesh, panel: int, rng: tuple[int, int]) -> np.ndarray:
    """Global boundary vertices on outline range i0..i1 of a panel, in forward order, counted by
    walking the boundary loop between the vertices at the two range ends."""
    loop = mesh.boundary_loops[panel]
    om = mesh.outline_maps[panel]
    v0, v1 = om.vertex[rng[0]], om.vertex[rng[1]]
    if v0 < 0 or v1 < 0:
        raise ValueError(f"range ends {rng} of panel {mesh.panel_names[panel]!r} are not vertices")
    pos = {int(v): j for j, v in enumerate(loop)}
    j0, j1 = pos[int(v0)], pos[int(v1)]
    count = (j1 - j0) % len(loop) + 1
    return loop[(j0 + np.arange(count)) % len(loop)]


def _outward_normal(pattern: Pattern, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(outward normal, normal of a counter-clockwise (u, v) triangle), both in the world."""
    p = pattern.panels[k]
    r = np.asarray(p.placement.rotation, dtype=float)
    src = pattern.source_file or "<pattern>"
    if not np.all(np.isfinite(r)) or np.abs(r.T @ r - np.eye(3)).max() > 1e-4:
        raise PatternError(f"{src}: panel {p.name!r}: placement rotation_matrix is not a rotation")
    if not np.all(np.isfinite(p.placement.translation_m)):
        raise PatternError(f"{src}: panel {p.name!r}: placement translation_m is not finite")
    outward = r @ np.array([0.0, 0.0, 1.0 if p.orientation == "ccw" else -1.0])
    ccw_normal = np.cross(r[:, 0], r[:, 1])
    return outward, ccw_normal


def build_sewn_mesh(pattern: Pattern, edge_length_cm: float = DEFAULT_EDGE_LENGTH_CM, *,
                    algorithm: str = DEFAULT_ALGORITHM) -> SewnMesh:
    """Sample every panel boundary, triangulate every panel, and pair the seam vertices."""
    from ..limits import check_mesh_size
    t_start = time.perf_counter()
    src = pattern.source_file or "<pattern>"
    check_mesh_size(pattern, edge_length_cm)     # every caller, not only the commands
    bnd: PatternBoundary = sample_boundary(pattern, edge_length_cm)
    h = bnd.edge_length_cm
    normals = [_outward_normal(pattern, k) for k in range(len(pattern.panels))]

    uv_parts, x_parts, tri_parts, tpanel, vpanel, bflag, cflag = [], [], [], [], [], [], []
    loops, offsets = [], []
    offset = 0
    with gmsh_session():
        for k, pb in enumerate(bnd.panels):
            try:
                pts, tris = triangulate_polygon(pb.uv, h, algorithm=algorithm)
            except TriangulationError as exc:
                raise PatternError(f"{src}: panel {pb.name!r}: cannot triangulate the outline at edge length "
                                   f"{h:g} cm (does it cross itself?): {exc}") from exc
            outward, ccw_normal = normals[k]
            if np.dot(outward, ccw_normal) < 0:       # the outward side sees (u, v) clockwise
                tris = tris[:, [0, 2, 1]]
            m = len(pb.uv)
            offsets.append(offset)
            loops.append(offset + np.arange(m))
            uv_parts.append(pts)
            x_parts.append(pattern.panels[k].placement.to_world(pts))
            tri_parts.append(tris.astype(np.int64) + offset)
            tpanel.append(np.full(len(tris), k))
            vpanel.append(np.full(len(pts), k))
            bflag.append(np.arange(len(pts)) < m)
            cf = np.zeros(len(pts), dtype=bool)
            cf[:m] = pb.corner
            cflag.append(cf)
            offset += len(pts)

    landmark_vertex = {}
    outline_maps = []
    for k, pb in enumerate(bnd.panels):
        for name, v in pb.landmarks.items():
            landmark_vertex[(pb.name, name)] = int(offsets[k] + v)
        outline_maps.append(_outline_map(pb, offsets[k]))

    stitch_pairs, pairs, pair_stitch, seen = [], [], [], set()
    for ss in bnd.stitches:
        ga = offsets[ss.panel_a] + ss.a
        gb = offsets[ss.panel_b] + ss.b
        stitch_pairs.append(np.column_stack([ga, gb]).astype(np.int32))
        for u, v in zip(ga, gb):
            key = (min(u, v), max(u, v))
            if u == v or key in seen:
                continue
            seen.add(key)
            pairs.append((u, v))
            pair_stitch.append(ss.index)

    mesh = SewnMesh(
        panel_names=[p.name for p in pattern.panels],
        uv_cm=np.vstack(uv_parts), x0=np.vstack(x_parts),
        triangles=np.vstack(tri_parts).astype(np.int32),
        triangle_panel=np.concatenate(tpanel).astype(np.int32),
        vertex_panel=np.concatenate(vpanel).astype(np.int32),
        boundary=np.concatenate(bflag), corner=np.concatenate(cflag),
        sewing_pairs=np.array(pairs, dtype=np.int32).reshape(-1, 2),
        pair_stitch=np.array(pair_stitch, dtype=np.int32),
        boundary_loops=loops, landmark_vertex=landmark_vertex, outline_maps=outline_maps,
        stitch_pairs=stitch_pairs,
        stitches=[StitchInfo(st.kind, st.a.panel, tuple(st.a.range), st.b.panel, tuple(st.b.range),
                             st.orientation, st.gathered) for st in pattern.stitches],
        outward_normals=np.array([n[0] for n in normals]),
        outline_area_cm2=np.array([abs(p.signed_area_cm2()) for p in pattern.panels]),
        edge_length_cm=h, source_file=pattern.source_file, garment_id=pattern.garment_id,
        body_id=pattern.body_id)
    mesh.build_seconds = time.perf_counter() - t_start
    return mesh


def _outline_map(pb, offset: int) -> OutlineMap:
    """Locate every outline point of a panel on its boundary loop (see OutlineMap)."""
    n = len(pb.outline_cm)
    m = len(pb.s)
    per = pb.perimeter
    s_out = pb.arc[:n]
    # the boundary vertex at or before each outline point, along the loop
    j = np.searchsorted(pb.s, s_out + 1e-9, side="right") - 1
    j = np.mod(j, m)
    j_next = np.mod(j + 1, m)
    a_uv, b_uv = pb.uv[j], pb.uv[j_next]
    chord = b_uv - a_uv
    rel = pb.outline_cm - a_uv
    c2 = np.einsum("ij,ij->i", chord, chord)
    t = np.einsum("ij,ij->i", rel, chord) / c2
    w = (chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0]) / c2
    vertex = np.full(n, -1, dtype=np.int64)
    gap = np.mod(s_out - pb.s[j], per)
    on_vertex = (gap <= 1e-7) | (per - gap <= 1e-7)
    vertex[on_vertex] = offset + j[on_vertex]
    t[on_vertex] = 0.0
    w[on_vertex] = 0.0
    return OutlineMap(a=offset + j, b=offset + j_next, t=t, w=w, vertex=vertex)


def outline_from_uv(mesh: SewnMesh, uv_cm: np.ndarray, detail: bool = True) -> dict[str, np.ndarray]:
    """New outline_cm of every panel from new vertex positions (N, 2) in cm.

    With ``detail`` the outline between two boundary vertices follows their chord with its
    original shape (scaled and turned with the chord); without, it is the chord itself.
    """
    uv = np.asarray(uv_cm, dtype=float)
    if uv.shape != mesh.uv_cm.shape:
        raise ValueError(f"uv_cm must have shape {mesh.uv_cm.shape}, got {uv.shape}")
    out = {}
    for name, om in zip(mesh.panel_names, mesh.outline_maps):
        a, b = uv[om.a], uv[om.b]
        chord = b - a
        pts = a + om.t[:, None] * chord
        if detail:
            pts = pts + om.w[:, None] * np.column_stack([-chord[:, 1], chord[:, 0]])
        is_vertex = om.vertex >= 0
        pts[is_vertex] = uv[om.vertex[is_vertex]]
        out[name] = pts
    return out
