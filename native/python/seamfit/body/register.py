"""Any mesh as a target: the base body's mesh fitted onto a body of another topology (a
scan, a character, a decimated or remeshed body), so that it has the vertex-to-vertex
correspondence grading needs.

Four stages (docs/bodies.md, "Registration"):

1. Checks (``check_registrable``), cheap and first: a mesh in other units, on another up
   axis (a Y-up body as Blender's OBJ importer leaves a Z-up file), facing another way,
   not closed, or wider or deeper than the template's standing A-pose gets a one-line
   error naming the reason and the fix.
2. Measurements first: the scan's height, bust and hip, taken by ``seamfit.body.measure``
   as on any mesh, are met by the body model (hm08, ``from_measurements``).
3. The model's shape on the surface: every macro and local modifier, and a translation,
   fitted to the scan by bounded Gauss-Newton on point-to-plane distances. Much of the
   scan far from this body means another pose: refused before the costly stage 4.
   A template of another mesh than hm08 is scaled to the scan's height and hip instead.
4. A non-rigid surface fit: each template vertex is pulled to its closest point on the
   scan, and each point of the scan pulls its nearest template vertex (so that no part of
   the scan is left uncovered); the displacement is kept smooth by a bi-Laplacian term
   whose weight falls from stiff to supple over the rounds. Matches farther than a few
   cm, or whose normals disagree, are dropped.

The result is reported with its error: the mean and the largest distance from the
registered body's vertices to the scan's surface, and back (mm).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import BodyError
from .io import Body

__all__ = ["Registration", "RegistrationError", "check_frame", "check_registrable", "register_body",
           "same_topology"]

# The non-rigid fit's stiffness schedule, one closest-point round each: bi-Laplacian
# weights per vertex area (the template's mean vertex area is the unit, so the schedule
# does not depend on its size). A second round per stiffness let the vertices drift along
# the surface (vertex error 1.7 -> 1.3 mm on a decimated body without it, same surface error).
STIFFNESS = (20.0, 5.0, 1.5, 0.3)
MODEL_ROUNDS = 4                  # Gauss-Newton rounds of the model's shape on the surface
MODEL_STRIDE = 4                  # and every 4th template vertex in them (a few dozen parameters)
MATCH_DISTANCE_M = 0.05           # matches farther than this are dropped
MATCH_COS = 0.5                   # and those whose normals differ by more than 60 degrees
BACK_SPACING = 0.5                # the scan's points that pull the template: this many template
                                  # vertex spacings apart (about 10 per template vertex)
CG_RTOL = 1e-6                    # each round's solve, warm-started from the last round's fit


class RegistrationError(BodyError):
    """A mesh that cannot be registered; the message names the reason and the fix."""


@dataclass
class Registration:
    """The template fitted onto a scan, and how close it came."""

    body: Body                     # the template's topology, on the scan's surface
    scan: str
    template: str
    mean_mm: float                 # registered body's vertices -> scan surface
    max_mm: float
    scan_mean_mm: float            # scan's vertices -> registered surface
    scan_max_mm: float
    seconds: float
    stages: dict = field(default_factory=dict)
    measurements: dict = field(default_factory=dict)
    model: dict | None = None      # the measurements stage's fit (hm08 templates)

    def report(self) -> dict:
        return {"scan": self.scan, "template": self.template,
                "error_mm": {"mean": round(self.mean_mm, 2), "max": round(self.max_mm, 2)},
                "scan_to_body_mm": {"mean": round(self.scan_mean_mm, 2), "max": round(self.scan_max_mm, 2)},
                "scan_measurements_cm": {k: round(float(v), 2) for k, v in self.measurements.items()},
                "model": self.model, "seconds": round(self.seconds, 2),
                "stages_s": {k: round(v, 2) for k, v in self.stages.items()},
                "n_vertices": self.body.n_vertices, "n_faces": self.body.n_faces}


def same_topology(a: Body, b: Body) -> bool:
    return a.n_vertices == b.n_vertices and np.array_equal(a.faces, b.faces)


def target_for(base: Body, target: Body, *, gender: str = "female", progress=None):
    """The target body as grading needs it: ``target`` itself when it shares the base
    body's mesh, else ``target`` registered onto the base body's mesh. Returns (body,
    Registration or None); a target that cannot be registered raises
    :class:`RegistrationError` from its checks, before any fitting."""
    if same_topology(base, target):
        return target, None
    reg = register_body(target, template=base, gender=gender, name=target.name, progress=progress)
    reg.body.source_file = target.source_file
    return reg.body, reg


# ----------------------------------------------------------------------------- the surface fit

def _vertex_normals(V, F) -> np.ndarray:
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], fn)
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)


def _vertex_areas(V, F) -> np.ndarray:
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    out = np.zeros(len(V))
    for k in range(3):
        np.add.at(out, F[:, k], area / 3.0)
    return out


def _laplacian(n: int, F):
    """The uniform graph Laplacian I - D^-1 A of the mesh's edges."""
    from scipy.sparse import coo_matrix, diags, identity
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
    A = coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)).tocsr()
    A.data[:] = 1.0                                   # each edge once, whichever faces share it
    deg = np.asarray(A.sum(axis=1)).ravel()
    return (identity(n, format="csr") - diags(1.0 / np.maximum(deg, 1)) @ A).tocsr()


def _surface_fit(V0: np.ndarray, F: np.ndarray, scan: Body, scan_index=None, progress=None) -> np.ndarray:
    """The template vertices V0 (faces F) moved onto the scan's surface (stage 3)."""
    from scipy.sparse import diags
    from scipy.sparse.linalg import cg
    from scipy.spatial import cKDTree
    from .closest import SurfaceIndex, area_samples

    F = np.asarray(F, np.int64)
    n = len(V0)
    index = scan_index or SurfaceIndex(scan.vertices, scan.faces)
    sF = np.asarray(scan.faces, np.int64)
    sfn = np.cross(scan.vertices[sF[:, 1]] - scan.vertices[sF[:, 0]], scan.vertices[sF[:, 2]] - scan.vertices[sF[:, 0]])
    s_area = 0.5 * np.linalg.norm(sfn, axis=1)
    sfn = sfn / np.maximum(2.0 * s_area[:, None], 1e-300)
    # The scan's points that pull the template, spread by area, each weighted by the area it
    # stands for in units of the template's mean vertex area.
    a0 = _vertex_areas(V0, F)
    unit = float(a0.mean())
    S, s_tri, s_area_each = area_samples(scan.vertices, scan.faces, BACK_SPACING * np.sqrt(unit))
    s_weight = s_area_each / unit
    s_normal = sfn[s_tri]
    L = _laplacian(n, F)
    R = (L.T @ L).tocsr()
    V = V0.copy()
    RV0 = R @ V0
    rounds = len(STIFFNESS)
    for r, alpha in enumerate(STIFFNESS):
        vn = _vertex_normals(V, F)
        w = _vertex_areas(V, F) / unit
        d, tri, Q, _ = index.query(V, within=MATCH_DISTANCE_M)
        ok = (d < MATCH_DISTANCE_M) & (np.einsum("ij,ij->i", vn, sfn[tri]) > MATCH_COS)
        w_f = np.where(ok, w, 0.0)
        # each scan sample pulls its nearest template vertex
        dist, k = cKDTree(V).query(S, workers=-1)
        ok_b = (dist < MATCH_DISTANCE_M) & (np.einsum("ij,ij->i", vn[k], s_normal) > MATCH_COS)
        w_b = np.bincount(k[ok_b], weights=s_weight[ok_b], minlength=n)
        pull_b = np.stack([np.bincount(k[ok_b], weights=s_weight[ok_b] * S[ok_b, c], minlength=n)
                           for c in range(3)], axis=1)
        A = (diags(w_f + w_b) + alpha * R).tocsr()
        rhs = w_f[:, None] * Q + pull_b + alpha * RV0
        # Conjugate gradients from the last fit: it moves little from one round to the next.
        pre = diags(1.0 / A.diagonal())
        V = np.stack([cg(A, rhs[:, c], x0=V[:, c], rtol=CG_RTOL, atol=0.0, maxiter=2000, M=pre)[0]
                      for c in range(3)], axis=1)
        if progress is not None:
            progress((r + 1) / rounds)
    return V


# ----------------------------------------------------------------------------- checks

# A standing body's height in other units: the unit whose plausible range holds it.
_UNITS = (("millimetres", 1000.0, 0.001), ("centimetres", 100.0, 0.01), ("inches", 39.37, 0.0254))
# The template's A-pose is 0.61-0.66 of its height wide and 0.24-0.28 deep over the body
# model's shapes (size 2 to 16, apple, pear, men); arms raised or lowered by a third of
# their angle, or a seated or lying body, fall outside these bands.
WIDTH_RANGE = (0.45, 0.80)
DEPTH_RANGE = (0.15, 0.40)
FAR_M = 0.05                      # after the model fit, scan surface this far off ...
FAR_SHARE = 0.02                  # ... over this share of its area: another pose


def check_registrable(scan: Body):
    """The checks before any fitting: raises :class:`RegistrationError` with one line naming
    the reason and the fix; returns the validation report."""
    from .validate import validate_body
    where = scan.where
    rep = validate_body(scan)
    for e in rep.errors:
        if "units tall" not in e:            # units are told by check_frame, with the scale that fixes them
            raise RegistrationError(e)
    check_frame(scan)
    if rep.stats.get("boundary_edges", 0):
        raise RegistrationError(f"{where}: not closed: {rep.stats['boundary_edges']} boundary edges around "
                                f"{_holes(scan)} hole(s) (e.g. {_hole_where(scan)}); registration needs a closed "
                                "surface: fill the holes (in Blender: Select > All by Trait > Non Manifold, "
                                "then Face > Fill)")
    extent = np.ptp(scan.vertices[np.unique(scan.faces)], axis=0)
    width, depth = extent[0] / extent[2], extent[1] / extent[2]
    if not (WIDTH_RANGE[0] <= width <= WIDTH_RANGE[1] and DEPTH_RANGE[0] <= depth <= DEPTH_RANGE[1]):
        what = ("arms raised" if width > WIDTH_RANGE[1] else "arms lowered" if width < WIDTH_RANGE[0]
                else "bent or leaning")
        raise RegistrationError(f"{where}: another pose: the body is {width:.2f} of its height wide and "
                                f"{depth:.2f} deep (looks {what}); registration needs the template's standing "
                                f"A-pose ({WIDTH_RANGE[0]}-{WIDTH_RANGE[1]} wide, {DEPTH_RANGE[0]}-{DEPTH_RANGE[1]} "
                                "deep): arms hanging about 40 degrees from the body, legs slightly apart")
    return rep


def check_frame(body: Body) -> None:
    """Units and axes: a body in other units, lying down (a Y-up body as Blender's OBJ
    importer leaves a Z-up file) or facing another way raises :class:`RegistrationError`
    naming the fix. A target of the base body's mesh needs no registration, but no less
    these: grade checks it so before any work."""
    where = body.where
    extent = np.ptp(body.vertices[np.unique(body.faces)], axis=0) if body.n_faces else np.zeros(3)
    long_axis = int(np.argmax(extent))
    tall = float(extent[long_axis])
    if not 0.3 <= tall <= 3.0:
        for unit, per_m, scale in _UNITS:
            if 1.2 * per_m <= tall <= 2.2 * per_m:
                raise RegistrationError(f"{where}: wrong units: the body is {tall:.4g} units tall, which looks like "
                                        f"{unit}; seamfit needs metres: scale it by {scale:g}")
        raise RegistrationError(f"{where}: wrong units: the body is {tall:.4g} units tall; seamfit needs a "
                                "standing body in metres (0.3 to 3 m tall)")
    if long_axis != 2:
        raise RegistrationError(f"{where}: wrong axes: " + _up_fix(body, long_axis))
    facing = _facing(body)
    if facing != "-Y":
        turn = {"+Y": "180", "+X": "-90", "-X": "+90"}[facing]
        raise RegistrationError(f"{where}: wrong axes: the body faces {facing} (its toes point that way); seamfit "
                                f"needs it facing -Y: rotate it {turn} degrees about Z")


def _up_fix(scan: Body, axis: int) -> str:
    """Which axis the height runs along, which way the head is, and the rotation that
    stands the body up; the head is the end whose cross-section is one loop (the feet
    are two)."""
    from .measure import _Slicer
    name = "XYZ"[axis]
    turn = np.roll(np.eye(3), 2 - axis, axis=0)       # the long axis becomes Z
    V = scan.vertices @ turn.T
    s = _Slicer(Body(V, scan.faces, name=scan.name))
    lo, hi = s.z0 + 0.03 * s.H, s.z1 - 0.03 * s.H
    head_up = len(s.loops(hi)) <= len(s.loops(lo))
    sign = "+" if head_up else "-"
    if axis == 1:
        rot = f"rotate it {'+' if head_up else '-'}90 degrees about X"
        blender = (" (Blender's OBJ importer lays a Z-up file down so by default: import it with Up axis Z, "
                   "or rotate it and apply the rotation, Object > Apply > Rotation, before exporting)")
    else:
        rot = f"rotate it {'-' if head_up else '+'}90 degrees about Y"
        blender = ""
    return f"the body is {sign}{name}-up (its height runs along {name}); seamfit needs Z up: {rot}{blender}"


def _holes(scan: Body) -> int:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    a, b = _boundary_edges(scan)
    if not len(a):
        return 0
    ids, inv = np.unique(np.r_[a, b], return_inverse=True)
    m = len(a)
    g = coo_matrix((np.ones(m), (inv[:m], inv[m:])), shape=(len(ids), len(ids)))
    return int(connected_components(g, directed=False)[0])


def _hole_where(scan: Body) -> str:
    a, _ = _boundary_edges(scan)
    z = scan.vertices[a, 2]
    z0, z1 = scan.vertices[:, 2].min(), scan.vertices[:, 2].max()
    return f"at {100 * (np.median(z) - z0) / (z1 - z0):.0f} % of the height, vertex {int(a[0])}"


def _boundary_edges(scan: Body):
    F = scan.faces.astype(np.int64)
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    b = u[c == 1]
    return b[:, 0], b[:, 1]


def _facing(scan: Body) -> str:
    """Which way the toes point: the feet's vertices (lowest 4 % of the height) lie in
    front of the ankles' (4-10 %)."""
    V = scan.vertices
    z = V[:, 2]
    z0, H = z.min(), np.ptp(z)
    feet = V[z < z0 + 0.04 * H, :2]
    ankles = V[(z >= z0 + 0.04 * H) & (z < z0 + 0.10 * H), :2]
    if len(feet) < 3 or len(ankles) < 3:
        return "-Y"                       # no feet to tell by: left to the pose checks
    dx, dy = feet.mean(axis=0) - ankles.mean(axis=0)     # the two feet's sideways parts cancel
    if abs(dy) >= abs(dx):
        return "-Y" if dy < 0 else "+Y"
    return "-X" if dx < 0 else "+X"


# ----------------------------------------------------------------------------- registration

def register_body(scan: Body, template: Body | None = None, *, gender: str = "female",
                  name: str | None = None, progress=None) -> Registration:
    """Fit ``template`` (default: the body model's hm08 mesh, the sample bodies') onto
    ``scan``; the result has the template's vertices and faces, on the scan's surface.
    ``progress(stage, fraction)`` is told the stages. Raises :class:`RegistrationError`
    (checks first, before any fitting) for a mesh that cannot be registered."""
    from .closest import SurfaceIndex
    from .measure import body_measurements
    from .shape_model import hm08_faces

    t0 = time.perf_counter()
    stages = {}

    def tell(stage, fraction=None):
        if progress is not None:
            progress(stage, fraction)

    check_registrable(scan)
    where = scan.where
    tell("measurements")
    try:
        measured = body_measurements(scan)
    except BodyError as exc:
        raise RegistrationError(f"{where}: another pose: cannot take the template's measurements "
                                f"({str(exc).split(': ', 1)[-1]}); registration needs a standing A-pose") from None
    m = {k: float(measured[k]) for k in ("height", "bust", "waist", "hip")}
    hm08 = template is None or np.array_equal(template.faces, hm08_faces())
    faces = hm08_faces() if template is None else template.faces
    index = SurfaceIndex(scan.vertices, scan.faces)
    model = None
    if hm08:
        V, model = _model_fit(scan, m, gender, index, tell, stages)
    else:
        V = _scaled_template(template, scan, m)
    stages["measurements"] = stages.get("measurements", time.perf_counter() - t0)
    _check_pose(scan, V, faces, where)
    tell("surface fit", 0.0)
    t1 = time.perf_counter()
    V = _surface_fit(V, faces, scan, index, progress=lambda f: tell("surface fit", f))
    stages["surface_fit"] = time.perf_counter() - t1
    d = index.query(V)[0]
    back = _once_index(V, faces).query(scan.vertices[np.unique(scan.faces)])[0]
    body = Body(V, faces, name=name or f"{scan.name}_registered")
    reg = Registration(body=body, scan=where, template=template.where if template is not None else "hm08 body model",
                       mean_mm=1000 * float(d.mean()), max_mm=1000 * float(d.max()),
                       scan_mean_mm=1000 * float(back.mean()), scan_max_mm=1000 * float(back.max()),
                       seconds=time.perf_counter() - t0, stages=stages, measurements=m, model=model)
    body.meta["registration"] = reg.report()
    return reg


def _model_fit(scan: Body, m: dict, gender: str, index, tell, stages):
    """Stage 2: the body model fitted to the scan's measurements, then its shape (every
    macro and local modifier, and a translation) to the scan's surface, by bounded
    Gauss-Newton on point-to-plane distances."""
    from scipy.optimize import lsq_linear
    from .made_to_measure import _Parameters, from_measurements
    from .measure import MEASUREMENTS
    from .shape_model import hm08_faces, shape_vertices

    t0 = time.perf_counter()
    made = from_measurements({k: m[k] for k in ("height", "bust", "hip")}, gender=gender)
    stages["measurements"] = time.perf_counter() - t0
    tell("model fit", 0.0)
    t1 = time.perf_counter()
    p = _Parameters(gender, MEASUREMENTS)
    x = p.vector(made.shape)
    F = hm08_faces().astype(np.int64)
    lo_s, hi_s = scan.vertices.min(axis=0), scan.vertices.max(axis=0)
    V = shape_vertices(p.shape(x), place=False)
    lo, hi = V.min(axis=0), V.max(axis=0)
    # placed as the model places a body (feet on the floor, box centred), on the scan's box
    offset = np.r_[0.5 * (lo_s[:2] + hi_s[:2]) - 0.5 * (lo[:2] + hi[:2]), lo_s[2] - lo[2]]
    n_x = len(x)
    for r in range(MODEL_ROUNDS):
        V_all = shape_vertices(p.shape(x), place=False) + offset
        # Every MODEL_STRIDE-th vertex, weighted up by the stride: a few dozen parameters
        # need far fewer than all the vertices' closest points.
        V = V_all[::MODEL_STRIDE]
        nrm = _vertex_normals(V_all, F)[::MODEL_STRIDE]
        area = _vertex_areas(V_all, F)
        d, tri, Q, _ = index.query(V, within=MATCH_DISTANCE_M)
        w = np.sqrt(MODEL_STRIDE * area[::MODEL_STRIDE] / area.mean()) * (d < MATCH_DISTANCE_M)
        J = np.empty((len(V), n_x + 3))
        for i in range(n_x):
            h = 1e-3 if x[i] + 1e-3 <= p.hi[i] else -1e-3        # probe inside the range
            xi = x.copy()
            xi[i] += h
            Vi = shape_vertices(p.shape(xi), place=False)[::MODEL_STRIDE] + offset
            J[:, i] = np.einsum("ij,ij->i", nrm, Vi - V) / h
        J[:, n_x:] = nrm
        J *= w[:, None]
        res = w * np.einsum("ij,ij->i", nrm, V - Q)
        # a light pull to the measurements' fit keeps parameters the surface cannot tell apart still
        A = np.vstack([J, np.hstack([0.05 * np.eye(n_x), np.zeros((n_x, 3))])])
        b = np.concatenate([-res, np.zeros(n_x)])
        step = lsq_linear(A, b, bounds=(np.r_[p.lo - x, -np.inf, -np.inf, -np.inf],
                                        np.r_[p.hi - x, np.inf, np.inf, np.inf]), method="bvls").x
        x = np.clip(x + step[:n_x], p.lo, p.hi)
        offset = offset + step[n_x:]
        tell("model fit", (r + 1) / MODEL_ROUNDS)
    stages["model_fit"] = time.perf_counter() - t1
    V = shape_vertices(p.shape(x), place=False) + offset
    return V, {"gender": gender, "measurements_fit": made.report()["achieved_cm"],
               "parameters": p.shape(x).as_dict()}


def _scaled_template(template: Body, scan: Body, m: dict) -> np.ndarray:
    """Stage 2 for a template of another mesh: scaled to the scan's height, and across
    to its hip girth, feet on the scan's floor, box centred on the scan's."""
    from .measure import body_measurements
    mt = body_measurements(template)
    V = template.vertices.copy()
    lo, hi = V.min(axis=0), V.max(axis=0)
    c = np.r_[0.5 * (lo[:2] + hi[:2]), lo[2]]
    across = m["hip"] / mt["hip"]
    V = (V - c) * np.array([across, across, m["height"] / mt["height"]])
    lo_s, hi_s = scan.vertices.min(axis=0), scan.vertices.max(axis=0)
    return V + np.r_[0.5 * (lo_s[:2] + hi_s[:2]), lo_s[2]]


def _once_index(V, faces):
    """A closest-point index on the template for one query: sampled at the side of its mean
    triangle, not at half its median edge (its face and hands are fine-meshed: 0.94 M
    samples and 0.9 s to build that way, 0.16 M and 0.2 s so, the query a little slower)."""
    from .closest import SurfaceIndex
    area = _vertex_areas(V, faces).sum() / len(faces)
    return SurfaceIndex(V, faces, spacing=float(np.sqrt(area)))


def _check_pose(scan: Body, V, faces, where: str) -> None:
    """Another pose than the template's: much of the scan's surface far from the
    template fitted to its measurements and shape."""
    sF = scan.faces.astype(np.int64)
    P = scan.vertices[sF].mean(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(scan.vertices[sF[:, 1]] - scan.vertices[sF[:, 0]],
                                         scan.vertices[sF[:, 2]] - scan.vertices[sF[:, 0]]), axis=1)
    d = _once_index(V, faces).query(P, within=FAR_M)[0]
    far = d > FAR_M
    share = float(area[far].sum() / area.sum())
    if share > FAR_SHARE:
        z = P[far, 2]
        z0, H = scan.vertices[:, 2].min(), np.ptp(scan.vertices[:, 2])
        raise RegistrationError(
            f"{where}: another pose: {100 * share:.0f} % of the surface (from {100 * (z.min() - z0) / H:.0f} to "
            f"{100 * (z.max() - z0) / H:.0f} % of the height) lies more than {100 * FAR_M:.0f} cm from the template "
            "fitted to its shape; registration needs the template's standing A-pose: arms hanging about 40 "
            "degrees from the body, legs slightly apart")
