# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's only door to seamfit. No bpy here: these functions run in worker threads
on plain data captured from the scene on the main thread.
"""
from __future__ import annotations

import importlib
import importlib.util
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .cache import CACHE, digest
from .jobs import Cancelled


class AddonError(Exception):
    """A problem the user can fix, shown as is (like seamfit's own errors)."""


def seamfit_module(name: str = ""):
    """Import ``seamfit`` or one of its public modules (``seamfit.PUBLIC_MODULES``: the add-on
    uses nothing below them) with a readable failure."""
    full = "seamfit" + (f".{name}" if name else "")
    try:
        if name and name not in importlib.import_module("seamfit").PUBLIC_MODULES:
            raise ValueError(f"{full} is not one of seamfit's public modules")
        return importlib.import_module(full)
    except ImportError as exc:
        raise AddonError(f"{full} is not available in the installed seamfit ({exc}); "
                         "reinstall the seamfit extension") from exc


def user_errors() -> tuple[type[BaseException], ...]:
    """Exceptions whose message is meant for the user."""
    try:
        from seamfit.errors import SeamfitError
        return (SeamfitError, AddonError)
    except ImportError:
        return (AddonError,)


def seamfit_version() -> str:
    try:
        import seamfit
        return str(seamfit.__version__)
    except ImportError as exc:
        return f"not available ({exc})"


# ---------------------------------------------------------------------------
# Patterns

def load_pattern(path: str):
    """sewpat-1 or a GarmentCode specification, detected from the content."""
    return seamfit_module("pattern").load_pattern(path)


def check_pattern(pattern) -> list[str]:
    """Refuse a broken pattern (seamfit's PatternError lists every error); return the warnings."""
    return [str(w) for w in seamfit_module("pattern").check_pattern(pattern).warnings]


def edges_in_order(panel):
    """The panel's edges in outline order, or None when they do not run around the outline."""
    try:
        return seamfit_module("pattern").edges_in_order(panel, panel.name)
    except seamfit_module("errors").PatternError:
        return None


# Under this key of a panel's changes: its edges split at added points and joined at deleted ones.
POINTS_KEY = "points"


def edit_pattern(pattern, changes: dict):
    """``pattern`` with new edge curves: ``changes[panel][edge id]`` = dict(kind, p0, p1,
    ctrl, arc), after the splits and joins listed under ``changes[panel][POINTS_KEY]``
    (dict(op="split", edge, at, new_id, point) or dict(op="join", edges, point), in order);
    outlines sampled again, stitches kept on their edges."""
    points = seamfit_module("pattern")
    Edge = points.Edge
    for name, per in changes.items():
        for op in per.get(POINTS_KEY, []):
            # The edits validate the whole pattern once they are all made.
            if op["op"] == "split":
                pattern, _ = points.split_edge(pattern, name, op["edge"], op["at"], new_id=op["new_id"],
                                               point=op["point"], check=False)
            else:
                pattern = points.join_edges(pattern, name, *op["edges"], point=op["point"], check=False)
    new = {name: {eid: Edge(id=eid, start=0, end=0, kind=d["kind"], p0=tuple(d["p0"]), p1=tuple(d["p1"]),
                            ctrl=[tuple(c) for c in d.get("ctrl", [])], arc=d.get("arc"))
                  for eid, d in per.items() if eid != POINTS_KEY}
           for name, per in changes.items() if per}
    return points.edit_edges(pattern, new)


def arc_through(p0, p1, samples):
    return seamfit_module("pattern").arc_through(p0, p1, samples)


def cubic_through(p0, p1, samples, t=None):
    return seamfit_module("pattern").cubic_through(p0, p1, samples, t)


def check_edited(pattern, where: str) -> list[str]:
    """Validate an edited pattern as a file is validated; the first error as one line
    naming the panel or stitch (and how many more there are). Returns the warnings."""
    source = pattern.source_file
    pattern.source_file = where
    try:
        report = seamfit_module("pattern").validate_pattern(pattern)
    finally:
        pattern.source_file = source
    if report.errors:
        more = len(report.errors) - 1
        raise AddonError(report.errors[0] + (f" (and {more} more error{'s' if more > 1 else ''})" if more else ""))
    return [str(w) for w in report.warnings]


def pattern_to_json(pattern) -> str:
    sewpat = seamfit_module("pattern")
    return json.dumps(sewpat.pattern_to_dict(pattern), sort_keys=True)


def pattern_from_json(text: str, source: str = "<blend>"):
    sewpat = seamfit_module("pattern")
    return sewpat.pattern_from_dict(json.loads(text), source)


def save_pattern(pattern, path: str) -> None:
    """sewpat-1, written atomically; seamfit refuses to write over the pattern's own source file."""
    seamfit_module("pattern").save_pattern(pattern, path)


def save_svg(patterns: list, path: str, labels: list[str] | None = None) -> None:
    """True-scale drawing; several patterns are overlaid, the first being the base."""
    seamfit_module("pattern").write_svg(path, patterns, labels=labels)


def side_points_cm(pattern, side) -> np.ndarray:
    range_indices = seamfit_module("pattern").range_indices
    panel = pattern.panel(side.panel)
    return panel.outline_cm[range_indices(side.range, panel.n_vertices)]


def stitch_lengths_cm(pattern, stitch) -> tuple[float, float]:
    """Lengths of both sides, as the file gives them or measured along the outline."""
    polyline_length = seamfit_module("pattern").polyline_length
    la = stitch.length_a_cm
    lb = stitch.length_b_cm
    if la is None:
        la = polyline_length(side_points_cm(pattern, stitch.a))
    if lb is None:
        lb = polyline_length(side_points_cm(pattern, stitch.b))
    return float(la), float(lb)


def stitch_pairs_world(pattern, stitch, spacing_m: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Matching points along both sides of a stitch, in world metres, for display:
    both sides sampled at the same fractions of their length (side b runs backwards
    for a 'reversed' stitch)."""
    pa, pb = pattern.panel(stitch.a.panel), pattern.panel(stitch.b.panel)
    a = pa.placement.to_world(side_points_cm(pattern, stitch.a))
    b = pb.placement.to_world(side_points_cm(pattern, stitch.b))
    if stitch.orientation == "reversed":
        b = b[::-1]
    length = max(_polylen(a), _polylen(b))
    count = max(2, int(np.ceil(length / spacing_m)) + 1)
    t = np.linspace(0.0, 1.0, count)
    return _resample(a, t), _resample(b, t)


def _polylen(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0


def _resample(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 0:
        return np.repeat(p[:1], len(t), axis=0)
    s /= s[-1]
    return np.stack([np.interp(t, s, p[:, k]) for k in range(p.shape[1])], axis=1)


# ---------------------------------------------------------------------------
# Bodies

@dataclass
class BodyInput:
    """A body mesh captured from the scene: world coordinates in metres, triangles."""
    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    key: str = ""

    def __post_init__(self):
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int64)
        if not self.key:
            self.key = digest(self.vertices, self.triangles)


def body_object(body: BodyInput):
    """seamfit's Body for the captured mesh (cached by content)."""
    def make():
        return seamfit_module("body").Body(body.vertices, body.triangles, name=body.name)
    return CACHE.get("body", body.key, make)


def body_measurements(body: BodyInput) -> dict:
    key = "measure:" + body.key
    return CACHE.get("body", key, lambda: seamfit_module("body").body_measurements(body_object(body)))


def body_report(body: BodyInput) -> dict:
    """Validation messages and key measurements (cm) of a body."""
    b = seamfit_module("body")
    BodyError = seamfit_module("errors").BodyError
    try:
        sb = body_object(body)
        report = b.validate_body(sb)
    except BodyError as exc:        # a body that loads but fails its checks, or does not load
        return {"errors": [str(exc)], "warnings": [], "measurements": {}}
    errors = [str(e) for e in (getattr(report, "errors", None) or [])]
    warnings = [str(w) for w in (getattr(report, "warnings", None) or [])]
    measurements = {}
    if not errors:
        try:
            m = body_measurements(body)
        except BodyError as exc:    # valid mesh but not measurable as a body
            return {"errors": [str(exc)], "warnings": warnings, "measurements": {}}
        measurements = {k: float(m[k]) for k in ("height", "bust", "waist", "hip") if k in m}
    return {"errors": errors, "warnings": warnings, "measurements": measurements}


def measurement_names() -> tuple:
    """seamfit's measurement names, in its order (seamfit.body.MEASUREMENTS); none when
    seamfit cannot be imported (the panels then say to reinstall it)."""
    try:
        return tuple(seamfit_module("body").MEASUREMENTS)
    except AddonError:
        return ()


def unit_factor_cm(unit: str) -> float:
    """cm per unit of ``unit`` ("cm", "in"), as seamfit's measurement files convert them."""
    return float(seamfit_module("body").MEASUREMENT_UNITS[unit])


def load_size_chart(path: str) -> list[dict]:
    """The bodies of a measurement file (seamfit JSON, Seamly2D .vit / .vst), each as
    {"name", "gender", "cm"}; a file that cannot make bodies raises seamfit's one-line error."""
    sets = seamfit_module("body").load_measurement_sets(path)
    return [{"name": s.name, "gender": s.gender, "cm": {k: float(v) for k, v in s.cm.items()}} for s in sets]


def make_body(cm: dict, gender: str, name: str, job):
    """seamfit's body made to the measurements ``cm`` (any subset of measurement_names());
    seamfit.body.MeasuredBody. Bad values raise seamfit's MeasurementError naming the field."""
    b = seamfit_module("body")
    job.update(stage="fitting the body model", fraction=0.1)
    made = b.from_measurements(b.MeasurementSet(dict(cm), name=name, gender=gender), name=name)
    job.update(stage="made", fraction=1.0)
    return made


def needs_registration(base: BodyInput | None, target: BodyInput) -> bool:
    """Whether ``target`` has another mesh than ``base`` (the sample bodies' mesh when no
    base is given): grading then registers the base mesh onto it."""
    bodies = seamfit_module("body")
    if base is not None:
        return not bodies.same_topology(body_object(base), body_object(target))
    faces = bodies.hm08_faces()
    return not (len(target.triangles) == len(faces) and np.array_equal(target.triangles, faces))


def quick_check(body: BodyInput, registering: bool) -> str:
    """seamfit's checks before any fitting (units, up axis with the fix, facing, holes,
    pose): the one-line reason a body is refused, or "". An open mesh is refused only when
    it must be registered (the distance field copes with holes)."""
    reg = seamfit_module("body")
    sb = body_object(body)
    try:
        reg.check_registrable(sb)
    except reg.RegistrationError as exc:
        if not registering and str(exc).startswith(f"{sb.where}: not closed:"):
            return ""
        return str(exc)
    return ""


def _registration_key(base: BodyInput, target: BodyInput, gender: str) -> str:
    return digest("register", base.key, target.key, gender)


def registration_done(base: BodyInput, target: BodyInput, gender: str = "female"):
    """The registration of ``target`` onto ``base``'s mesh if one was made, else None."""
    done = CACHE.peek("register", _registration_key(base, target, gender))
    return None if done is None else done[1]


def registered_target(base: BodyInput, target: BodyInput, job=None, gender: str = "female", show_fraction=True):
    """(seamfit Body on the base body's mesh, Registration or None): ``target`` itself when it
    shares the base body's mesh, else the base mesh registered onto it (cached by content;
    seamfit's checks refuse a mesh that cannot be registered before any fitting)."""
    if not needs_registration(base, target):
        return body_object(target), None

    def tell(stage, fraction=None):
        if job is not None:
            job.update(stage=f"registering: {stage}", fraction=fraction if show_fraction else None)

    def make():
        body, reg = seamfit_module("body").target_for(body_object(base), body_object(target),
                                                      gender=gender, progress=tell)
        if job is not None:
            job.check()
        return body, reg
    return CACHE.get("register", _registration_key(base, target, gender), make)


def fit_ease(body: BodyInput, g: "Garment") -> dict:
    """Ease in cm (garment tape girth minus body girth) at the body's bust, waist and hip
    levels, by seamfit's fit measure; a level the garment does not cover is left out."""
    fit = seamfit_module("opt")
    levels = body_measurements(body).get("levels_z_m")
    report = fit.ease_report(body_object(body), g.x, g.triangles, levels)
    return {k: float(v) for k, v in report.items() if v is not None}


def body_sdf(body: BodyInput, settings: dict | None = None):
    """seamfit's signed distance field of the body (cached here, and by seamfit on disk)."""
    settings = dict(settings or {})
    key = digest(body.key, settings)
    return CACHE.get("sdf", key, lambda: seamfit_module("body").build_sdf(body_object(body), **settings))


# ---------------------------------------------------------------------------
# Sewn mesh

def sewn_mesh(pattern_json: str, edge_length_cm: float):
    key = digest(pattern_json, round(float(edge_length_cm), 6))

    def make():
        m = seamfit_module("mesh")
        return m.build_sewn_mesh(pattern_from_json(pattern_json), edge_length_cm=float(edge_length_cm))
    return CACHE.get("mesh", key, make), key


# ---------------------------------------------------------------------------
# Device

def device_status() -> dict:
    """Whether the installed seamfit can use a CUDA GPU here, and why not."""
    try:
        ok, why = seamfit_module("device").cuda_available()
        name = ""
        if ok:
            name = seamfit_module("device").cuda_device_name(0)
        return {"cuda": bool(ok), "why": why, "name": name, "error": ""}
    except Exception as exc:   # a broken install is shown in the panel, not raised while drawing
        return {"cuda": False, "why": "", "name": "", "error": str(exc)}


def check_device(device: str, n_vertices: int = 0) -> str:
    """The device simulations run on ("cpu" or "cuda") for a garment of n_vertices;
    fails at once, like the command line, when CUDA is asked for and cannot be used."""
    return seamfit_module("device").resolve_device(device, problem_size=int(n_vertices))


# ---------------------------------------------------------------------------
# Drape and grade (filled in as seamfit.sim and seamfit.opt provide them)

@dataclass
class Garment:
    """A garment mesh ready for the scene: pattern (uv_cm), positions x (m), triangles,
    sewing pairs, panel of each triangle, stretch ratio per vertex."""
    panel_names: list
    uv_cm: np.ndarray
    x: np.ndarray
    triangles: np.ndarray
    triangle_panel: np.ndarray
    sewing_pairs: np.ndarray
    pair_stitch: np.ndarray | None = None
    stretch: np.ndarray | None = None


def garment(mesh, x: np.ndarray | None = None) -> Garment:
    """``mesh`` (a seamfit SewnMesh) at positions ``x`` (default: its flat start positions)."""
    x = np.asarray(mesh.x0 if x is None else x, dtype=np.float64)
    return Garment(panel_names=list(mesh.panel_names), uv_cm=np.asarray(mesh.uv_cm), x=x,
                   triangles=np.asarray(mesh.triangles), triangle_panel=np.asarray(mesh.triangle_panel),
                   sewing_pairs=np.asarray(mesh.sewing_pairs).reshape(-1, 2),
                   pair_stitch=np.asarray(getattr(mesh, "pair_stitch", None))
                   if getattr(mesh, "pair_stitch", None) is not None else None,
                   stretch=stretch_ratio_per_vertex(mesh.uv_cm, x, mesh.triangles))


@dataclass
class MeshOutput:
    pattern_json: str
    garment: Garment
    stats: dict


def run_mesh(pattern_json: str, edge_length_cm: float, job) -> MeshOutput:
    job.update(stage="meshing", fraction=0.1)
    mesh, _ = sewn_mesh(pattern_json, edge_length_cm)
    job.update(stage="meshed", fraction=1.0)
    stats = mesh.stats() if hasattr(mesh, "stats") else {}
    return MeshOutput(pattern_json, garment(mesh), stats)


@dataclass
class RunInputs:
    pattern_name: str
    pattern_json: str
    edge_length_cm: float
    base: BodyInput
    sim: dict = field(default_factory=dict)
    target: BodyInput | None = None
    strengths: dict = field(default_factory=dict)
    grade: dict = field(default_factory=dict)      # GradeSettings fields from the scene's settings
    device: str = "auto"
    method: str = "adjoint"     # seamfit.opt.grade's GradeSettings.method
    grade_options: dict = field(default_factory=dict)   # further GradeSettings fields


def stretch_ratio_per_vertex(uv_cm: np.ndarray, x: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Mean over the incident edges of |x_i - x_j| / |p_i - p_j| (the stretching ratio of
    Wang 2018, section 6, shown in its Fig. 8)."""
    p = np.zeros((len(uv_cm), 3))
    p[:, :2] = 0.01 * np.asarray(uv_cm)
    tri = np.asarray(triangles)
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    rest = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    cur = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)
    ratio = np.where(rest > 0, cur / np.maximum(rest, 1e-12), 1.0)
    acc = np.zeros(len(x))
    cnt = np.zeros(len(x))
    np.add.at(acc, e[:, 0], ratio)
    np.add.at(acc, e[:, 1], ratio)
    np.add.at(cnt, e[:, 0], 1)
    np.add.at(cnt, e[:, 1], 1)
    return np.where(cnt > 0, acc / np.maximum(cnt, 1), 1.0)


def principal_strains_pct(uv_cm: np.ndarray, x: np.ndarray, triangles: np.ndarray):
    """Principal strains of each triangle in % (singular values of the map from the pattern
    to the body, minus one): (largest per face, smallest per face, largest per vertex as the
    area-weighted mean of its faces)."""
    tri = np.asarray(triangles, dtype=np.int64)
    p = 0.01 * np.asarray(uv_cm, dtype=np.float64)[tri]          # (n, 3, 2) rest, metres
    q = np.asarray(x, dtype=np.float64)[tri]                      # (n, 3, 3) on the body
    dp = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)    # (n, 2, 2)
    dq = np.stack([q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]], axis=2)    # (n, 3, 2)
    det = dp[:, 0, 0] * dp[:, 1, 1] - dp[:, 0, 1] * dp[:, 1, 0]
    ok = np.abs(det) > 1e-14
    inv = np.zeros_like(dp)
    inv[ok, 0, 0], inv[ok, 1, 1] = dp[ok, 1, 1] / det[ok], dp[ok, 0, 0] / det[ok]
    inv[ok, 0, 1], inv[ok, 1, 0] = -dp[ok, 0, 1] / det[ok], -dp[ok, 1, 0] / det[ok]
    f = dq @ inv                                                  # (n, 3, 2) deformation gradient
    s = np.linalg.svd(f, compute_uv=False) if len(f) else np.zeros((0, 2))
    smax = np.where(ok, 100.0 * (s[:, 0] - 1.0), 0.0)
    smin = np.where(ok, 100.0 * (s[:, 1] - 1.0), 0.0)
    area = 0.5 * np.abs(det)
    acc = np.zeros(len(x))
    w = np.zeros(len(x))
    for k in range(3):
        np.add.at(acc, tri[:, k], area * smax)
        np.add.at(w, tri[:, k], area)
    vmax = np.where(w > 0, acc / np.maximum(w, 1e-30), 0.0)
    return smax, smin, vmax


@dataclass
class DrapeOutput:
    pattern_json: str
    garment: Garment
    converged: bool
    residual: float
    iterations: int
    seconds: float
    message: str
    fit: dict


def _sim_objects(sim_cfg: dict, device: str, n_vertices: int = 0):
    """seamfit's Fabric and SimSettings for the scene's simulation settings (their fields by
    name: "fabric" and SimSettings' own; "sdf_spacing" is the bodies' fields')."""
    sim = seamfit_module("sim")
    fabric = sim.Fabric(**{k: float(v) for k, v in sim_cfg.get("fabric", {}).items()})
    opts = {k: v for k, v in sim_cfg.items() if k not in ("fabric", "sdf_spacing")}
    return fabric, sim.SimSettings(**opts, device=check_device(device, n_vertices))


def _simulator(mesh, sdf, sim_cfg: dict, device: str):
    fabric, settings = _sim_objects(sim_cfg, device, mesh.n_vertices)
    return seamfit_module("sim").Simulator(mesh, sdf, fabric, settings), settings


def _drape_progress(job, tracker):
    """(stage(name), callback(iteration, residual) -> bool) reporting seamfit.progress's
    stages, share and time left for a drape on the job's bar, as `seamfit drape` shows them."""
    def show(info: dict, **extra) -> None:
        snap = tracker.observe(info)
        job.update(stage=snap.stage, fraction=snap.fraction, eta=snap.eta, **extra)

    def callback(iteration: int, residual: float) -> bool:
        # Called from inside seamfit's solvers: answer False to stop, never raise.
        try:
            show({"stage": "drape", "sim_iteration": iteration, "residual": residual},
                 objective=residual, iteration=iteration)
        except Cancelled:
            return False
        return not job.cancelled
    return (lambda name: show({"stage": name})), callback


def base_drape(inp: RunInputs, job):
    """The base garment draped on the base body (cached): (mesh, DrapeResult, mesh_key)."""
    spacing = inp.sim["sdf_spacing"]
    tracker = seamfit_module("progress").for_drape(pattern_from_json(inp.pattern_json), float(inp.edge_length_cm),
                                                   float(spacing), device=inp.device, pictures=0)
    stage, callback = _drape_progress(job, tracker)
    stage("meshing")
    mesh, mesh_key = sewn_mesh(inp.pattern_json, inp.edge_length_cm)
    stage("body fields")
    sdf = body_sdf(inp.base, {"spacing": spacing})
    key = digest(mesh_key, inp.base.key, inp.sim, inp.device)
    stage("drape")

    def make():
        simulator, settings = _simulator(mesh, sdf, inp.sim, inp.device)
        tracker.plan.tolerance = float(settings.tolerance)
        # As `seamfit drape` does: hint placements are wrapped around the body first, and
        # a settle that stagnates restarts from a drape of a coarser mesh.
        res = seamfit_module("sim").drape_coarse_to_fine(
            simulator, pattern_from_json(inp.pattern_json), mode="auto", progress=callback)
        job.check()     # a cancelled drape is never cached
        if getattr(res, "cancelled", False):
            raise Cancelled()
        return res
    return mesh, CACHE.get("drape", key, make), mesh_key


def run_drape(inp: RunInputs, job) -> DrapeOutput:
    mesh, res, _ = base_drape(inp, job)
    job.update(stage="measuring the fit")
    g = garment(mesh, res.x)
    return DrapeOutput(inp.pattern_json, g, bool(res.converged), float(res.residual),
                       int(res.iterations), float(res.seconds), str(res.message), _fit_or_none(inp.base, g))


def _fit_or_none(body: BodyInput, g: Garment) -> dict:
    try:
        return fit_ease(body, g)
    except user_errors():   # a body seamfit cannot measure: no fit lines, the result stands
        return {}


@dataclass
class GradeOutput:
    pattern_json: str           # the adjusted pattern (sewpat-1)
    base_pattern_json: str
    garment: Garment            # sewn from the adjusted pattern, draped on the target body
    objective: float
    iterations: int
    converged: bool
    method: str                 # seamfit's name of the grading method
    message: str
    fit: dict
    report: dict
    result: Any                 # seamfit's GradeResult, for writing the command line's files
    base_name: str
    target_name: str
    target_body: Any = None     # seamfit's Body of the target
    warnings: list = field(default_factory=list)    # for the user, e.g. a base pattern not made for the base body
    registration: Any = None    # seamfit's Registration when the target has another mesh than the base body


def _grade_progress(job, tracker):
    """seamfit's progress callback for a grading: seamfit.progress turns its events into
    named stages, a fraction that never goes backwards and the time left, as the command
    line shows them."""
    def progress(info: dict) -> bool:
        # Called from inside seamfit's solvers (some in C++): answer False to stop, never raise.
        try:
            report(info)
        except Cancelled:
            return False
        return not job.cancelled

    def report(info: dict) -> None:
        snap = tracker.observe(info)
        search = info.get("stage") == "optimize" and info.get("iteration") is not None
        job.update(stage=snap.stage, fraction=snap.fraction, eta=snap.eta,
                   objective=info.get("objective") if search else None,
                   iteration=info.get("iteration") if search else None)
    return progress


def grade_settings(inp: RunInputs):
    """seamfit's GradeSettings for the inputs; a bad further setting is a one-line error."""
    opt = seamfit_module()
    import dataclasses
    fields = {f.name for f in dataclasses.fields(opt.GradeSettings)}
    given = {"strengths", "method", "edge_length_cm", "sdf_spacing", "device", *inp.grade}
    unknown = sorted(set(inp.grade_options) - (fields - given))
    if unknown:
        raise AddonError(f"More grading settings: {', '.join(unknown)}: not a setting of seamfit's grading here "
                         f"(it takes {', '.join(sorted(fields - given))})")
    settings = opt.GradeSettings(
        strengths=dict(inp.strengths), method=inp.method, edge_length_cm=float(inp.edge_length_cm),
        sdf_spacing=float(inp.sim["sdf_spacing"]), device=inp.device, **inp.grade, **inp.grade_options)
    try:
        settings.validate()
    except ValueError as exc:
        raise AddonError(f"grading settings: {exc}") from None
    return settings


# Ease (cm) at the level where a garment rests on its body beyond which it looks made for
# another body (the garment's girth is then nearer the other body's than its base body's).
_MISMATCH_EASE_CM = 1.5


def fit_warnings(base_ease: dict, base_girths: dict, target_girths: dict, base_name: str, target_name: str,
                 pattern_body: str = "") -> list[str]:
    """Whether the base pattern looks made for the base body, from the base drape: at the
    level where the garment rests on the body (its smallest ease, where a garment hangs
    from), its girth should be nearer the base body's girth than the target's. Also the
    pattern's own body name when it names the target rather than the base. Lines for the
    user, with the numbers; empty when all is well."""
    out = []
    levels = {k: v for k, v in (base_ease or {}).items()
              if v is not None and k in base_girths and k in target_girths}
    if levels:
        level = min(levels, key=lambda k: levels[k])
        e0 = float(levels[level])
        g0, g1 = float(base_girths[level]), float(target_girths[level])
        garment = g0 + e0
        nearer_target = abs(garment - g1) < abs(garment - g0)
        if nearer_target and abs(e0) > _MISMATCH_EASE_CM:
            size = "larger" if e0 > 0 else "smaller"
            out.append(f"the base pattern looks made for a {size} body than {base_name}: at the {level} the draped "
                       f"base garment measures {garment:.1f} cm, {base_name} {g0:.1f} cm (ease {e0:+.1f} cm), "
                       f"{target_name} {g1:.1f} cm; grading assumes the base pattern fits the base body")
    tag = (pattern_body or "").strip().lower()
    if tag and tag not in base_name.lower() and tag in target_name.lower():
        out.append(f"the base pattern says it was made for {pattern_body!r}, which names the target "
                   f"{target_name}, not the base body {base_name}")
    return out


def _fit_check(inp: RunInputs, report: dict) -> list[str]:
    ease = (report.get("ease_cm") or {}).get("base") or {}
    try:
        m0, m1 = body_measurements(inp.base), body_measurements(inp.target)
    except user_errors():       # bodies seamfit cannot measure: nothing to compare
        return []
    girths = [{k: float(m[k]) for k in ("bust", "waist", "hip") if m.get(k) is not None} for m in (m0, m1)]
    body = pattern_from_json(inp.pattern_json).body_id or ""
    return fit_warnings(ease, girths[0], girths[1], inp.base.name, inp.target.name, body)


def run_grade(inp: RunInputs, job) -> GradeOutput:
    """seamfit.opt.grade on the captured inputs, cached by their content: the same inputs
    give the previous result at once. Within a run seamfit reuses its own caches of body
    distance fields and base drapes, so changing strengths, the method or the target skips those."""
    opt = seamfit_module()
    check_device(inp.device)
    # The method is part of the result's key only: the distance fields and the base drape
    # it starts from are seamfit's, keyed without it, so a new method reuses them.
    key = digest(inp.pattern_json, round(inp.edge_length_cm, 6), inp.base.key, inp.target.key,
                 inp.strengths, inp.grade, inp.sim, inp.method, inp.grade_options)
    SolveError = seamfit_module("errors").SolveError

    def make():
        pattern = pattern_from_json(inp.pattern_json)
        fabric, sim_settings = _sim_objects(inp.sim, inp.device)
        settings = grade_settings(inp)
        tracker = seamfit_module("progress").for_grading(pattern, settings, tolerance=float(sim_settings.tolerance))
        target, _ = registered_target(inp.base, inp.target, job, show_fraction=False)
        try:
            res = opt.grade(pattern, body_object(inp.base), target, settings,
                            fabric=fabric, sim_settings=sim_settings, progress=_grade_progress(job, tracker))
        except SolveError:
            job.check()         # cancelled: nothing is cached
            raise
        job.check()
        return res
    res = CACHE.get("grade", key, make)
    job.update(stage="done", fraction=1.0, eta=0.0)
    return grade_output(inp, res)


def grade_output(inp: RunInputs, res) -> GradeOutput:
    """The scene's view of seamfit's GradeResult ``res`` for the inputs ``inp``: the graded
    pattern named for the target, the garment on the target with its stretch, the fit."""
    import copy
    graded = copy.deepcopy(res.pattern)     # the cached result stays as seamfit made it
    graded.body_id = inp.target.name
    g = garment(res.mesh, res.x)
    g.uv_cm = np.asarray(res.uv_cm)
    g.stretch = stretch_ratio_per_vertex(res.uv_cm, res.x, res.mesh.triangles)
    r = res.report
    ease = (r.get("ease_cm") or {}).get("result") or {}
    # A fine mesh graded coarse-to-fine with no search of its own: the search was the coarse level's.
    coarse = r.get("coarse_level") or {}
    searched = coarse if "objective_final" in coarse and not r.get("outer_iterations_done") else r
    return GradeOutput(
        pattern_json=pattern_to_json(graded), base_pattern_json=inp.pattern_json, garment=g,
        objective=float(searched["objective_final"]), iterations=int(searched["outer_iterations"]),
        converged=bool(r["converged"]), method=str(r.get("method", inp.method)), message=str(r["message"]),
        fit={k: float(v) for k, v in ease.items() if v is not None}, report=r, result=res,
        base_name=inp.base.name, target_name=inp.target.name, target_body=body_object(inp.target),
        warnings=[*_fit_check(inp, r), *((r.get("ease_cm") or {}).get("losses") or [])],
        registration=registration_done(inp.base, inp.target))


def write_grade_files(out, g: GradeOutput, picture: bool = True, inputs: dict | None = None,
                      extra: dict | None = None) -> list:
    """The files `seamfit grade` writes (pattern.json, pattern.svg, garment.obj, report.json,
    then pattern.png and drape.png), from a grading run of the add-on, by seamfit's one writer
    (seamfit.grade_files): a picture that cannot be drawn (Blender ships no matplotlib) is a
    ``pictures`` entry in the report, never a lost result."""
    files = seamfit_module("grade_files")
    base = pattern_from_json(g.base_pattern_json, source="base pattern")
    graded = pattern_from_json(g.pattern_json, source="graded pattern")
    report = {**g.report, **({"inputs": dict(inputs)} if inputs is not None else {}), **(extra or {})}
    report = files.write_grade_files(out, g.result, base, report, graded=graded, base_name=g.base_name,
                                     target_name=g.target_name, target_body=g.target_body, pictures=picture)
    return files.written_files(out, report)
