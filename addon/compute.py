# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's only door to seamfit. No bpy here: these functions run in worker threads
on plain data captured from the scene on the main thread.
"""
from __future__ import annotations

import importlib
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .cache import CACHE, digest
from .jobs import Cancelled


class AddonError(Exception):
    """A problem the user can fix, shown as is (like seamfit's own errors)."""


def seamfit_module(name: str = ""):
    """Import ``seamfit`` or one of its public modules with a readable failure."""
    full = "seamfit" + (f".{name}" if name else "")
    try:
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


def pattern_to_json(pattern) -> str:
    sewpat = seamfit_module("pattern.sewpat")
    return json.dumps(sewpat.pattern_to_dict(pattern), sort_keys=True)


def pattern_from_json(text: str, source: str = "<blend>"):
    sewpat = seamfit_module("pattern.sewpat")
    return sewpat.pattern_from_dict(json.loads(text), source)


def save_pattern(pattern, path: str) -> None:
    """sewpat-1, written atomically; seamfit refuses to write over the pattern's own source file."""
    seamfit_module("pattern").save_pattern(pattern, path)


def save_svg(patterns: list, path: str, labels: list[str] | None = None) -> None:
    """True-scale drawing; several patterns are overlaid, the first being the base."""
    seamfit_module("pattern").write_svg(path, patterns, labels=labels)


def side_points_cm(pattern, side) -> np.ndarray:
    from seamfit.pattern import range_indices
    panel = pattern.panel(side.panel)
    return panel.outline_cm[range_indices(side.range, panel.n_vertices)]


def stitch_lengths_cm(pattern, stitch) -> tuple[float, float]:
    """Lengths of both sides, as the file gives them or measured along the outline."""
    from seamfit.pattern.model import polyline_length
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
    from seamfit.errors import BodyError
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


def _welded_faces(g: "Garment") -> np.ndarray:
    """Triangles with each group of sewn vertices replaced by one of them: the panels form
    one surface, so a horizontal section of the garment is a closed loop round the body."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    n = len(g.x)
    pairs = np.asarray(g.sewing_pairs).reshape(-1, 2)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, n)
    np.minimum.at(first, label, np.arange(n))
    return first[label][np.asarray(g.triangles)]


def fit_ease(body: BodyInput, g: Garment) -> dict:
    """Ease in cm (garment girth minus body girth) at the body's bust, waist and hip levels;
    a level the garment does not reach around the body is left out."""
    b = seamfit_module("body")
    m = body_measurements(body)
    levels = m.get("levels_z_m", {})
    shell = b.Body(g.x, _welded_faces(g), name="garment")
    out = {}
    for key in ("bust", "waist", "hip"):
        if key not in levels or key not in m:
            continue
        girth = float(b.cross_section_girth(shell, float(levels[key])))
        if np.isfinite(girth) and girth > 0:
            out[key] = 100.0 * girth - float(m[key])
    return out


def body_sdf(body: BodyInput, settings: dict | None = None):
    settings = dict(settings or {})
    key = digest(body.key, settings)

    def make():
        b = seamfit_module("body")
        return b.build_sdf(body_object(body), **settings)
    return CACHE.get("sdf", key, make)


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
    """Which compute devices the installed seamfit can use."""
    out = {"cuda_built": False, "cuda_devices": 0, "cuda_name": "", "error": ""}
    try:
        from seamfit import _native
        core = _native.core()
        out["cuda_built"] = bool(getattr(core, "built_with_cuda", False))
        if out["cuda_built"]:
            out["cuda_devices"] = int(core.cuda_device_count())
            if out["cuda_devices"]:
                out["cuda_name"] = str(core.cuda_device_name(0))
    except Exception as exc:  # a broken install is shown, not raised, in a panel
        out["error"] = str(exc)
    return out


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
    opt: dict = field(default_factory=dict)
    device: str = "auto"


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


def fabric_defaults() -> dict:
    """seamfit's default fabric (numbers shown in the Simulation panel)."""
    try:
        from seamfit.sim import Fabric
        f = Fabric()
        return {k: float(getattr(f, k)) for k in ("stretch_stiffness", "sewing_stiffness",
                                                   "bending_stiffness", "density")}
    except Exception:   # seamfit without the simulator: the values it documents
        return {"stretch_stiffness": 1000.0, "sewing_stiffness": 8660.0,
                "bending_stiffness": 1.0e-5, "density": 0.2}


def _simulator(mesh, sdf, sim_cfg: dict, device: str):
    sim = seamfit_module("sim")
    from dataclasses import fields
    fabric = sim.Fabric(**{k: float(v) for k, v in sim_cfg.get("fabric", {}).items()})
    opts = {"mu": float(sim_cfg.get("mu", 0.01))}
    if sim_cfg.get("iterations"):
        opts["max_iterations"] = int(sim_cfg["iterations"])
    names = {f.name for f in fields(sim.SimSettings)}
    if "device" in names:
        opts["device"] = device
    elif device == "cuda":
        raise AddonError("this seamfit simulates on the CPU only; set Device to Auto or CPU")
    settings = sim.SimSettings(**opts)
    return sim.Simulator(mesh, sdf, fabric, settings), settings


def base_drape(inp: RunInputs, job, span=(0.1, 0.9)):
    """The base garment draped on the base body (cached): (mesh, DrapeResult, mesh_key)."""
    job.update(stage="meshing the pattern", fraction=0.01)
    mesh, mesh_key = sewn_mesh(inp.pattern_json, inp.edge_length_cm)
    job.update(stage="base body distance field", fraction=0.04)
    sdf = body_sdf(inp.base, {"spacing": inp.sim.get("sdf_spacing_m", 0.0025)})
    key = digest(mesh_key, inp.base.key, inp.sim, inp.device)

    def make():
        simulator, settings = _simulator(mesh, sdf, inp.sim, inp.device)
        # Start as `seamfit drape` does: hint placements are wrapped around the body first.
        x0, _ = seamfit_module("sim.dressing").initial_positions(
            mesh, pattern_from_json(inp.pattern_json), sdf, mode="auto")
        res = simulator.drape(x0, progress=job.callback("draping on the base body", span=span,
                                                        target=float(settings.tolerance)))
        job.check()     # a cancelled drape is never cached
        if getattr(res, "cancelled", False):
            raise Cancelled()
        return res
    return mesh, CACHE.get("drape", key, make), mesh_key


def run_drape(inp: RunInputs, job) -> DrapeOutput:
    mesh, res, _ = base_drape(inp, job)
    job.update(stage="measuring the fit", fraction=0.95)
    g = garment(mesh, res.x)
    return DrapeOutput(inp.pattern_json, g, bool(res.converged), float(res.residual),
                       int(res.iterations), float(res.seconds), str(res.message), _fit_or_none(inp.base, g))


def _fit_or_none(body: BodyInput, g: Garment) -> dict:
    try:
        return fit_ease(body, g)
    except user_errors():   # a body seamfit cannot measure: no fit lines, the result stands
        return {}
