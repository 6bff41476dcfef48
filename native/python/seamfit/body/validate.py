"""Body mesh checks before an SDF is built from it.

Errors (the body cannot be used): non-finite coordinates, no faces, face indices
out of range, implausible units (height outside 0.3-3 m: a body in mm or cm), a
surface that encloses no volume, or an orientation that cannot be made consistent
(non-orientable). Warnings (the body is usable): open boundaries and non-manifold
edges (the SDF then takes its sign from generalized winding numbers, which stay
robust there), degenerate triangles (ignored by distances), inconsistent or
inverted orientation (fixed: ``BodyReport.oriented_faces`` holds the repaired
faces, which ``build_sdf`` uses), an up axis other than Z.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components

from ..errors import BodyError
from .io import Body

__all__ = ["BodyReport", "validate_body", "check_body"]

MIN_HEIGHT_M = 0.3
MAX_HEIGHT_M = 3.0
# Beyond 1000 km (a body in micrometres, at most ~2e6) the file is broken rather than a body
# in other units, and products of such coordinates overflow.
MAX_COORD_M = 1e6
_SHOW = 5  # how many offending indices a message lists


@dataclass
class BodyReport:
    source: str
    errors: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    # Faces with orientation made consistent and outward (None when the body has errors).
    oriented_faces: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        return not self.errors

    @property
    def watertight(self) -> bool:
        return bool(self.stats.get("watertight", False))

    def as_dict(self) -> dict:
        return {"source": self.source, "ok": self.ok, "errors": list(self.errors),
                "warnings": list(self.warnings), "stats": dict(self.stats)}


def _few(idx) -> str:
    idx = [int(i) for i in np.asarray(idx).ravel()[:_SHOW]]
    return ", ".join(map(str, idx))


def validate_body(body: Body) -> BodyReport:
    """Check ``body`` and return errors, warnings and statistics (never raises for
    a bad mesh; see :func:`check_body`)."""
    where = body.where
    rep = BodyReport(source=where)
    V, F = body.vertices, body.faces
    nv, nf = len(V), len(F)
    rep.stats.update(n_vertices=nv, n_faces=nf)
    if nf == 0:
        rep.errors.append(f"{where}: the mesh has no faces")
    bad_v = np.flatnonzero(~np.isfinite(V).all(axis=1))
    if bad_v.size:
        rep.errors.append(f"{where}: {bad_v.size} vertices have NaN or infinite coordinates "
                          f"(vertex {_few(bad_v)})")
    bad_f = np.flatnonzero(((F < 0) | (F >= nv)).any(axis=1)) if nf else np.zeros(0, int)
    if bad_f.size:
        rep.errors.append(f"{where}: {bad_f.size} faces refer to vertices outside 0..{nv - 1} "
                          f"(face {_few(bad_f)}: {F[bad_f[0]].tolist()})")
    if rep.errors:
        return rep

    used = np.zeros(nv, bool)
    used[F.ravel()] = True
    far = np.flatnonzero(used & (np.abs(V).max(axis=1) > MAX_COORD_M))
    if far.size:
        rep.errors.append(f"{where}: {far.size} vertices lie more than {MAX_COORD_M:g} m (1000 km) from the origin "
                          f"(vertex {_few(far)} at {V[far[0]].tolist()}); seamfit needs a body in metres")
        return rep
    P = V[used]
    lo, hi = P.min(axis=0), P.max(axis=0)
    ext = hi - lo
    height = float(ext[2])
    rep.stats.update(bbox=[lo.tolist(), hi.tolist()], height_m=height,
                     unreferenced_vertices=int(nv - used.sum()))
    if not used.all():
        rep.warnings.append(f"{where}: {int(nv - used.sum())} vertices are used by no face (e.g. vertex "
                            f"{_few(np.flatnonzero(~used))}); they are ignored")
    if height > MAX_HEIGHT_M or height < MIN_HEIGHT_M:
        guess = (" (looks like millimetres: scale it by 0.001)" if height > 300 else
                 " (looks like centimetres: scale it by 0.01)" if height > 30 else "")
        rep.errors.append(f"{where}: the body is {height:.4g} units tall along Z; seamfit needs metres with Z up "
                          f"and a height between {MIN_HEIGHT_M} and {MAX_HEIGHT_M} m{guess}")
    if int(np.argmax(ext)) != 2 and ext[2] > 0:
        rep.warnings.append(f"{where}: the body's longest extent is along {'XYZ'[int(np.argmax(ext))]}, "
                            f"not Z; seamfit expects Z up")

    # Degenerate triangles: repeated vertices or (numerically) zero area.
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cr = np.cross(b - a, c - a)
    area2 = np.einsum("ij,ij->i", cr, cr)
    scale2 = max(float(np.max(ext)), 1e-300) ** 2
    degen = np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2]) |
                           (area2 <= (1e-14 * scale2) ** 2))
    rep.stats["degenerate_faces"] = int(degen.size)
    if degen.size:
        rep.warnings.append(f"{where}: {degen.size} degenerate (zero-area) faces, e.g. face {_few(degen)}; "
                            f"they are kept but contribute no area")

    # Edges: boundary (1 face), manifold (2), non-manifold (> 2).
    e_from = F.ravel()
    e_to = F[:, [1, 2, 0]].ravel()
    e_face = np.repeat(np.arange(nf), 3)
    keep = e_from != e_to
    e_from, e_to, e_face = e_from[keep], e_to[keep], e_face[keep]
    u = np.minimum(e_from, e_to).astype(np.int64)
    w = np.maximum(e_from, e_to).astype(np.int64)
    key = u * nv + w
    order = np.argsort(key, kind="stable")
    key_s = key[order]
    starts = np.flatnonzero(np.r_[True, key_s[1:] != key_s[:-1]])
    counts = np.diff(np.r_[starts, len(key_s)])
    direction = np.where(e_from < e_to, 1, -1)[order]
    net = np.add.reduceat(direction, starts) if len(starts) else np.zeros(0, int)
    first = order[starts]
    boundary = np.flatnonzero(counts == 1)
    nonmanifold = np.flatnonzero(counts > 2)
    rep.stats.update(edges=int(len(starts)), boundary_edges=int(boundary.size),
                     nonmanifold_edges=int(nonmanifold.size))
    if boundary.size:
        q = first[boundary[0]]
        rep.warnings.append(f"{where}: the mesh is open: {boundary.size} boundary edges (e.g. edge "
                            f"({u[q]}, {w[q]}) of face {e_face[q]}); inside/outside will use the robust "
                            f"generalized winding number")
    if nonmanifold.size:
        q = first[nonmanifold[0]]
        rep.warnings.append(f"{where}: {nonmanifold.size} non-manifold edges shared by more than two faces "
                            f"(e.g. edge ({u[q]}, {w[q]}) of face {e_face[q]}); inside/outside will use the "
                            f"robust generalized winding number")
    rep.stats["watertight"] = bool(boundary.size == 0 and nonmanifold.size == 0)
    rep.stats["manifold"] = bool(nonmanifold.size == 0)

    # Orientation: a manifold edge must be walked once each way by its two faces.
    two = np.flatnonzero(counts == 2)
    fa = e_face[order[starts[two]]]
    fb = e_face[order[starts[two] + 1]]
    same = net[two] != 0  # both faces walk the edge the same way
    rep.stats["consistently_oriented"] = bool(not same.any())
    flip = np.zeros(nf, bool)
    if same.any():
        flip, conflict = _orient(nf, fa, fb, same)
        if conflict is not None:
            k = two[conflict]
            q = first[k]
            rep.errors.append(f"{where}: the surface is not orientable: faces {fa[conflict]} and {fb[conflict]} "
                              f"around edge ({u[q]}, {w[q]}) cannot be oriented consistently")
            return rep
        rep.warnings.append(f"{where}: {int(same.sum())} edges join faces of opposite orientation "
                            f"(e.g. faces {fa[same][0]} and {fb[same][0]}); {int(flip.sum())} faces are flipped "
                            f"for a consistent orientation")
    faces = np.where(flip[:, None], F[:, ::-1], F).astype(np.int32)

    # Signed volume per connected component (about its centroid); inside-out
    # components are flipped.
    n_comp, vlabel = connected_components(
        coo_matrix((np.ones(len(e_from)), (e_from, e_to)), shape=(nv, nv)), directed=False)
    flabel = vlabel[faces[:, 0]]
    comps = np.unique(flabel)
    rep.stats["components"] = int(len(comps))
    total = 0.0
    vols = np.zeros(len(comps))
    for ci, c_id in enumerate(comps):
        sel = flabel == c_id
        fs = faces[sel]
        cen = V[np.unique(fs)].mean(axis=0)
        pa, pb, pc = V[fs[:, 0]] - cen, V[fs[:, 1]] - cen, V[fs[:, 2]] - cen
        vols[ci] = float(np.einsum("ij,ij->i", pa, np.cross(pb, pc)).sum() / 6.0)
    rep.stats["signed_volume_m3"] = float(vols.sum())
    box_vol = float(np.prod(np.maximum(ext, 1e-300)))
    if abs(vols.sum()) < 1e-4 * box_vol:
        rep.errors.append(f"{where}: the surface encloses no volume ({vols.sum():.3g} m^3 in a "
                          f"{box_vol:.3g} m^3 box); inside and outside cannot be told apart")
        return rep
    inverted = comps[vols < 0]
    if inverted.size:
        whole = inverted.size == len(comps)
        flip_f = np.isin(flabel, inverted)
        faces[flip_f] = faces[flip_f][:, ::-1]
        f0 = np.flatnonzero(flip_f)[0]
        rep.warnings.append(f"{where}: " + ("the body is inside-out (normals point inward, negative volume)"
                                            if whole else f"{inverted.size} of {len(comps)} components are "
                                            f"inside-out (e.g. the one with face {f0})") +
                            "; their faces are flipped")
        total = float(np.abs(vols).sum())
    else:
        total = float(vols.sum())
    rep.stats["inverted"] = bool(inverted.size)
    rep.stats["volume_litres"] = total * 1000.0
    rep.oriented_faces = np.ascontiguousarray(faces)
    return rep


def _orient(nf, fa, fb, same):
    """Flip flags making every manifold edge consistent: a parity 2-colouring of
    the face graph. Returns (flip, None), or (flip, index of a conflicting edge)."""
    g = coo_matrix((np.ones(len(fa)), (fa, fb)), shape=(nf, nf)).tocsr()
    g = g + g.T
    parity_of_edge = {}
    for x, y, s in zip(fa.tolist(), fb.tolist(), same.tolist()):
        parity_of_edge[(x, y)] = s
        parity_of_edge[(y, x)] = s
    flip = np.zeros(nf, bool)
    seen = np.zeros(nf, bool)
    for root in range(nf):
        if seen[root]:
            continue
        order, pred = breadth_first_order(g, root, directed=False, return_predecessors=True)
        seen[order] = True
        for node in order[1:].tolist():
            p = int(pred[node])
            flip[node] = flip[p] ^ parity_of_edge[(p, node)]
        if 2 * int(flip[order].sum()) > len(order):  # flip the minority instead
            flip[order] = ~flip[order]
    bad = np.flatnonzero((flip[fa] ^ flip[fb]) != same)
    return flip, (int(bad[0]) if bad.size else None)


def check_body(body: Body) -> BodyReport:
    """Validate ``body``; raise :class:`BodyError` listing every error, else return the report."""
    rep = validate_body(body)
    if rep.errors:
        raise BodyError("; ".join(rep.errors))
    return rep


def checked_body(path, warn=None):
    """The body at ``path`` with its faces oriented consistently outward (as ``seamfit
    validate`` repairs them and the SDF uses them); BodyError when it fails its checks,
    ``warn`` gets each warning."""
    from .io import load_body
    body = load_body(path)
    rep = check_body(body)
    for m in rep.warnings:
        if warn is not None:
            warn(m)
    if rep.oriented_faces is not None and not (rep.oriented_faces == body.faces).all():
        body = Body(body.vertices, rep.oriented_faces, name=body.name, source_file=body.source_file,
                    meta=dict(body.meta))
    return body
