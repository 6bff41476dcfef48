"""Python face of the quasistatic garment simulator Sim_phi(theta) (Wang 2018, section 4).

Units are SI throughout: positions x and pattern coordinates p in metres
(p = 0.01 * uv_cm), forces in newtons, energies in joules. See docs/simulator.md
for the model, the defaults and every deviation from the paper.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

from .._native import core
from ..device import require_device
from ..errors import DeviceError, SolveError
from ..settings import DRAPE, Addon, check_fields, setting

# Spring stiffness of a regular triangle lattice with edge a and springs
# Y/a: its plane-stress 2D Young's modulus is 2 Y / (sqrt(3) a), so a fabric of
# tensile stiffness E2D (N/m) gets Y = E2D * sqrt(3)/2 * a.
_LATTICE = math.sqrt(3.0) / 2.0


@dataclass
class Fabric:
    """Material of a medium-weight woven fabric (cotton twill / poplin class).

    stretch_stiffness: in-plane tensile stiffness E*thickness (N/m). Woven cotton
        extends about 0.5-1 % under the few N/m a garment carries; 1000 N/m puts
        gravity-induced strain of a hanging skirt near 0.1 %.
    sewing_stiffness: stiffness of one sewing spring (N/m). Ten times a mean
        patch spring (0.87 * stretch_stiffness), so a seam opens far less than
        the adjacent fabric stretches.
    bending_stiffness: flexural rigidity D (N m). Kawabata (KES-F) bending
        rigidity of shirting to twill cotton is 0.05-0.3 gf cm^2/cm, i.e.
        0.5-3e-5 N m; 1e-5 is the lighter end of medium weight.
    density: areal density (kg/m^2); 200 g/m^2 is a medium woven cotton.
    """
    stretch_stiffness: float = setting(
        1000.0, "in-plane tensile stiffness of the fabric (a medium woven cotton)", unit="N/m", low=0,
        low_open=True, flag="--stretch-stiffness", metavar="N/M", commands=DRAPE,
        addon=Addon("fabric_stretch", "Stretch stiffness (N/m)", minimum=1.0, soft_max=1e5))
    sewing_stiffness: float = setting(
        8660.0, "stiffness of one sewing spring", unit="N/m", low=0, flag="--sewing-stiffness",
        metavar="N/M", commands=DRAPE, addon=Addon("fabric_sewing", "Seam stiffness (N/m)", soft_max=1e6))
    bending_stiffness: float = setting(
        1.0e-5, "flexural rigidity of the fabric", unit="N m", low=0, flag="--bending-stiffness", metavar="NM",
        commands=DRAPE, addon=Addon("fabric_bending", "Bending stiffness (N·m)", soft_max=1e-3, precision=7))
    density: float = setting(
        0.2, "weight per area of the fabric", unit="kg/m^2", low=0, low_open=True, flag="--density",
        metavar="KG/M2", commands=DRAPE,
        addon=Addon("fabric_density", "Density (kg/m²)", minimum=0.001, soft_max=2.0, precision=3))

    def validate(self) -> None:
        """SolveError naming the fabric setting outside its range (seamfit.settings)."""
        try:
            check_fields(self, "fabric")
        except ValueError as exc:
            raise SolveError(f"fabric {exc}") from None


@dataclass
class SimSettings:
    """Solver and model controls.

    tolerance: convergence threshold on the relative residual |f| / |m g| (the
        norm of the net force over the norm of the vertex weights). At 1e-3 the
        unbalanced force is a thousandth of the weights and positions are good
        to about a millimetre (docs/simulator.md).
    mu: dimensionless barrier strength; the per-vertex weight is
        mu * barrier_length * g * m_i, so a vertex resting on the body under its
        own weight settles at phi = mu * barrier_length (1 mm by default).
    """
    method: str = setting("chebyshev", "drape solver", choices=("chebyshev", "newton"), flag="--method",
                          commands=DRAPE)
    tolerance: float = setting(
        1e-3, "relative residual |f| / |m g| a drape stops at", low=0, low_open=True, flag="--tolerance",
        metavar="R", commands=DRAPE)
    max_iterations: int = setting(   # Chebyshev iterations per stage (drape's --max-iterations: per method)
        40000, "most simulation iterations of a drape's stage", low=0,
        addon=Addon("sim_iterations", "Drape iterations", minimum=1, soft_max=100000))
    newton_max_iterations: int = 600   # Newton iterations per stage
    max_seconds: float = setting(
        0.0, "time budget per drape stage (0: no limit)", unit="s", low=0, flag="--max-seconds", metavar="S",
        commands=DRAPE)
    mu: float = setting(
        0.01, "strength of the log barrier that keeps cloth outside the body (0.01: a 1 mm gap under the "
        "cloth's own weight)", low=0, high=1, flag="--mu", commands=DRAPE,
        addon=Addon("mu", "Barrier μ", minimum=1e-6, soft_max=1.0, precision=4))
    barrier_length: float = 0.1
    barrier_distance: float = 0.01     # no barrier beyond 1 cm from the body
    barrier_interpolation: str = "cubic"  # "cubic" (C2 B-spline) or "trilinear" SDF reading
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    rho: float = 0.0                   # Chebyshev spectral radius, 0 = automatic
    rho_max: float = 0.9999995         # the automatic rho's upper bound (docs/simulator.md)
    alpha: float = 0.9                 # Jacobi step length
    warmup: int = 16
    check_every: int = 8
    progress_every: int = 50
    history_every: int = 10
    threads: int = 0                   # OpenMP threads, 0 = automatic
    precond_refresh: int = 4           # Chebyshev (CPU and GPU): refresh the springs' Jacobi blocks every N iterations
    far_bound: bool = True             # Chebyshev (CPU and GPU): bound, not sample, steps beyond the barrier's reach
    device: str = "cpu"                # where solves run: "cpu" or "cuda" (docs/gpu.md)
    # Dressing stages (see Simulator.drape).
    sew_first: bool = True             # stage 1: close the seams with gravity off
    sew_stage_tolerance: float = 1e-2
    sew_stage_gap_mm: float = 1.0
    chunk: int = 2500                  # Chebyshev iterations between stage checks
    polish: bool = True                # Newton after a Chebyshev settle that stopped short
    polish_iterations: int = 600
    # Block-Jacobi sweeps after a polish Newton step that leaves one vertex
    # holding most of the residual (a stiff local contact).
    polish_smoothing: int = 5

    def validate(self) -> None:
        try:
            check_fields(self, "sim")      # method, tolerance, mu, budgets (seamfit.settings)
        except ValueError as exc:
            raise SolveError(str(exc)) from None
        if self.barrier_interpolation not in ("cubic", "trilinear"):
            raise SolveError(f"unknown barrier_interpolation {self.barrier_interpolation!r} (cubic or trilinear)")
        if not (self.barrier_distance > 0):
            raise SolveError("barrier_distance must be > 0")
        if self.max_iterations < 0 or self.newton_max_iterations < 0 or self.polish_iterations < 0:
            raise SolveError("max_iterations must be >= 0")
        require_device(self.device, "the simulator", SolveError, runnable=False)
        if not (0 < self.rho_max < 1):
            raise SolveError(f"rho_max must lie in (0, 1), got {self.rho_max}")


@dataclass
class DrapeResult:
    x: np.ndarray                      # (N, 3) metres
    iterations: int
    seconds: float
    residual: float                    # relative residual |f| / |m g|
    converged: bool
    message: str
    max_sewing_gap_mm: float
    min_phi_mm: float
    energy_terms: dict[str, float]
    cancelled: bool = False
    stages: list[dict[str, Any]] = field(default_factory=list)
    history: dict[str, list] = field(default_factory=dict)

    def report(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "iterations": int(self.iterations), "seconds": float(self.seconds),
            "residual": float(self.residual), "converged": bool(self.converged),
            "cancelled": bool(self.cancelled), "message": self.message,
            "max_sewing_gap_mm": float(self.max_sewing_gap_mm), "min_phi_mm": float(self.min_phi_mm),
            "energy_terms": {k: float(v) for k, v in self.energy_terms.items()},
            "stages": [{k: v for k, v in s.items() if not k.startswith("history")} for s in self.stages],
        }


def _field(obj, name, required=True):
    if isinstance(obj, dict):
        val = obj.get(name)
    else:
        val = getattr(obj, name, None)
    if val is None and required:
        raise SolveError(f"the mesh has no field {name!r}")
    return val


class Simulator:
    """Quasistatic simulator of one sewn garment on one body.

    mesh: a SewnMesh-like object (uv_cm (N,2), x0 (N,3) m, triangles (T,3),
        sewing_pairs (K,2)); sdf: a SignedDistanceField-like object (values
        (nz,ny,nx), origin (3,), spacing) or None for no body.
    shirring: optional per-patch-spring scale r_s (see `springs`), or a scalar.
    """

    def __init__(self, mesh, sdf=None, fabric: Fabric | None = None, settings: SimSettings | None = None,
                 shirring=None):
        self.fabric = fabric or Fabric()
        self.settings = settings or SimSettings()
        self.fabric.validate()
        self.settings.validate()
        uv = np.asarray(_field(mesh, "uv_cm"), dtype=np.float64)
        tris = np.asarray(_field(mesh, "triangles"), dtype=np.int32)
        sew = _field(mesh, "sewing_pairs", required=False)
        sew = np.zeros((0, 2), np.int32) if sew is None or len(sew) == 0 else np.asarray(sew, dtype=np.int32)
        x0 = _field(mesh, "x0", required=False)
        if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) == 0:
            raise SolveError("mesh uv_cm must have shape (N, 2) with N > 0")
        if tris.ndim != 2 or tris.shape[1] != 3 or len(tris) == 0:
            raise SolveError("mesh triangles must have shape (T, 3) with T > 0")
        self.mesh = mesh
        self.p = 0.01 * uv
        self.x0 = None if x0 is None else np.asarray(x0, dtype=np.float64).reshape(-1, 3)
        if self.x0 is not None and len(self.x0) != len(uv):
            raise SolveError(f"mesh x0 has {len(self.x0)} rows for {len(uv)} vertices")
        self._core = core().Simulator(self.p, tris, sew, core().SimParams())
        self._gpu = None
        # Y from the tensile stiffness and the mean rest edge length (constant
        # afterwards, so d/dp does not see it).
        self.mean_edge = float(np.mean(self._core.rest_lengths))
        self._apply_params()
        self._core.threads = int(self.settings.threads)
        if sdf is not None:
            self.set_body(sdf)
        if shirring is not None:
            self.set_shirring(shirring)

    # ----------------------------------------------------------------- setup
    def _params(self, gravity_scale: float = 1.0, sewing_scale: float = 1.0):
        f, s = self.fabric, self.settings
        pr = core().SimParams()
        pr.stretch_Y = f.stretch_stiffness * _LATTICE * self.mean_edge
        pr.sewing_Y = f.sewing_stiffness * sewing_scale
        pr.bend_kb = f.bending_stiffness
        pr.density = f.density
        pr.gravity = [gravity_scale * g for g in s.gravity]
        pr.mu = s.mu
        pr.barrier_length = s.barrier_length
        pr.barrier_distance = s.barrier_distance
        pr.barrier_smooth = s.barrier_interpolation == "cubic"
        return pr

    def _apply_params(self, gravity_scale: float = 1.0, sewing_scale: float = 1.0):
        self._core.params = self._params(gravity_scale, sewing_scale)

    def set_body(self, sdf) -> None:
        # C-contiguous float32 is used in place by the core (a body's field is
        # hundreds of MB); anything else is converted once here.
        values = np.ascontiguousarray(_field(sdf, "values"), dtype=np.float32)
        origin = np.asarray(_field(sdf, "origin"), dtype=np.float64).reshape(3)
        spacing = float(_field(sdf, "spacing"))
        if values.ndim != 3:
            raise SolveError("SDF values must be a 3D array shaped (nz, ny, nx)")
        self.sdf = sdf
        self._core.set_sdf(values, origin, spacing)
        self._sdf_values = values  # shared with the core, which reads it in place

    def set_pattern(self, p: np.ndarray) -> None:
        """New rest state p (N, 2), metres. A DeviceArray p goes to the GPU mirror alone,
        which computes its rest state there; the CPU model (``self.p``) catches up only
        when a CPU method needs it (``sync_host_pattern``)."""
        from ..device_arrays import is_device
        if is_device(p):
            self.cuda().set_pattern_device(p)
            return
        self.p = np.asarray(p, dtype=np.float64).reshape(-1, 2).copy()
        self._core.set_pattern(self.p)
        if self._gpu is not None:
            self._gpu.device_pattern_ahead = False  # the GPU's sync() takes this one

    def sync_host_pattern(self) -> None:
        """Bring the CPU model to a pattern set on the GPU alone (a no-op otherwise)."""
        p = None if self._gpu is None else self._gpu.take_device_pattern()
        if p is not None:
            self.set_pattern(p)

    def set_shirring(self, r) -> None:
        r = np.broadcast_to(np.asarray(r, dtype=np.float64), (self._core.n_springs,)).copy()
        self._core.set_shirring(r)

    def set_sticking(self, vertices, targets, stiffness: float | np.ndarray = 100.0) -> None:
        """Pin vertices (pins, belts) to targets (len(vertices), 3) with stiffness N/m."""
        k = np.zeros(self.n_vertices)
        t = np.zeros((self.n_vertices, 3))
        vertices = np.asarray(vertices, dtype=np.int64)
        k[vertices] = stiffness
        t[vertices] = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
        self._core.set_sticking(k, t)

    # ---------------------------------------------------------------- layout
    @property
    def core(self):
        """The native CPU model, up to date (a pattern set on the GPU alone comes down first)."""
        return self._host_model()

    def _host_model(self):
        if self._gpu is not None and self._gpu.device_pattern_ahead:
            self.sync_host_pattern()
        return self._core

    @property
    def n_vertices(self) -> int:
        return self._core.n_vertices

    @property
    def springs(self) -> np.ndarray:
        return self._core.springs

    @property
    def sewing(self) -> np.ndarray:
        return self._core.sewing

    @property
    def masses(self) -> np.ndarray:
        return self._core.masses

    # ------------------------------------------------------------ evaluation
    def energy(self, x) -> tuple[float, dict[str, float]]:
        return self._host_model().energy(np.asarray(x, dtype=np.float64))

    def force(self, x) -> np.ndarray:
        """f = -dE/dx, shape (N, 3)."""
        return self._host_model().force(np.asarray(x, dtype=np.float64))

    def residual(self, x) -> float:
        return self._host_model().residual(np.asarray(x, dtype=np.float64))

    def hessian(self, x, psd: bool = False):
        """d2E/dx2 (the tangent stiffness, = -df/dx) as scipy.sparse.csc_matrix, 3N x 3N."""
        import scipy.sparse as sp
        data, indices, indptr, shape = self._host_model().hessian(np.asarray(x, dtype=np.float64), psd)
        return sp.csc_matrix((data, indices, indptr), shape=shape)

    def hess_vec(self, x, v, psd: bool = False) -> np.ndarray:
        return self._host_model().hess_vec(np.asarray(x, dtype=np.float64), np.asarray(v, dtype=np.float64), psd)

    def dfdp_T(self, x, lam) -> np.ndarray:
        """(df/dp)^T lam, shape (N, 2), for the adjoint (p in metres)."""
        return self._host_model().dfdp_T(np.asarray(x, dtype=np.float64), np.asarray(lam, dtype=np.float64))

    def phi(self, x, barrier_field: bool = False) -> np.ndarray:
        """phi at every vertex: the SDF grid's trilinear field (the body as
        measured), or with barrier_field the smooth field the barrier acts on."""
        return self._host_model().sample_phi(np.asarray(x, dtype=np.float64), barrier_field)

    def sewing_gaps(self, x) -> np.ndarray:
        return self._host_model().sewing_gaps(np.asarray(x, dtype=np.float64))

    def project_outside(self, x) -> tuple[np.ndarray, int]:
        """Vertices inside the body moved onto its surface (to the barrier's rest
        gap), as the solvers do with start positions; returns (x, how many)."""
        gap = self._host_model().projection_gap
        return self._host_model().project_outside(np.asarray(x, dtype=np.float64), 1e-9, gap)

    # --------------------------------------------------------------- solving
    def cuda(self):
        """The GPU mirror of this simulator (seamfit.sim.cuda.CudaSimulator),
        made on first use; raises DeviceError when no GPU can run it."""
        if self._gpu is None:
            from .cuda import CudaSimulator
            self._gpu = CudaSimulator(self)
        return self._gpu

    def _run(self, x, st, progress, device=None):
        """One core solve on the CPU or, for device "cuda", on the GPU mirror
        (synchronized with the current parameters first)."""
        dev = device or self.settings.device
        if dev == "cpu":
            return self._host_model().solve(x, st, progress)
        require_device(dev, "a solve", runnable=False)    # the GPU mirror checks cuda can run
        if st.method == 1:
            self._host_model()  # its line search runs on the CPU model
            return self.cuda().newton(x, settings=st, progress=progress)
        return self.cuda().solve(x, settings=st, progress=progress)

    def _settings(self, tolerance=None, max_iterations=None, method=None, max_seconds=None, smoothing=0):
        """Native solver settings; max_iterations=None means the method's budget."""
        s = self.settings
        st = core().SolveSettings()
        m = method or s.method
        st.method = 1 if m == "newton" else 0
        st.tolerance = float(tolerance if tolerance is not None else s.tolerance)
        if max_iterations is None:
            max_iterations = s.newton_max_iterations if m == "newton" else s.max_iterations
        st.max_iterations = int(max_iterations)
        st.max_seconds = float(s.max_seconds if max_seconds is None else max_seconds)
        st.rho = float(s.rho)
        st.rho_max = float(s.rho_max)
        st.alpha = float(s.alpha)
        st.warmup = int(s.warmup)
        st.check_every = int(s.check_every)
        st.progress_every = int(s.progress_every if st.method == 0 else 1)
        st.history_every = int(s.history_every)
        st.precond_refresh = int(s.precond_refresh)
        st.far_bound = bool(s.far_bound)
        st.newton_smoothing = int(smoothing)
        return st

    def solve(self, x0=None, *, tolerance=None, max_iterations=None, method=None,
              progress: Optional[Callable[[int, float], bool]] = None,
              gravity_scale: float = 1.0, sewing_scale: float = 1.0, device: Optional[str] = None) -> DrapeResult:
        """One quasistatic solve from x0 (default: the mesh's x0), on
        `device` ("cpu" or "cuda"; default settings.device)."""
        x = self._start(x0)
        self._apply_params(gravity_scale, sewing_scale)
        try:
            x, rep = self._run(x, self._settings(tolerance, max_iterations, method), progress, device)
        finally:
            self._apply_params()
        return self._result(x, [dict(rep, stage="solve")])

    def iterate(self, x0, iterations: int, device: Optional[str] = None) -> tuple[np.ndarray, dict]:
        """Exactly `iterations` Chebyshev iterations from x0 (the search's inexact
        steps): (x, report), without the summary a DrapeResult computes on the CPU
        (energy, sewing gaps, phi), which at 60K triangles costs more than the
        iterations on the GPU. report["residual"] is the relative residual at x.
        A DeviceArray x0 (GPU only) is advanced in place and returned."""
        from ..device_arrays import is_device
        if is_device(x0):
            if (device or self.settings.device) != "cuda":
                raise DeviceError("a garment state on the GPU needs device cuda")
            return x0, self.cuda().solve_device(x0, settings=self._settings(1e-12, int(iterations), "chebyshev"))
        x = self._start(x0)
        return self._run(x, self._settings(1e-12, int(iterations), "chebyshev"), None, device)

    def drape(self, x0=None, progress: Optional[Callable[[int, float], bool]] = None,
              device: Optional[str] = None, sewn: bool = False, polish: Optional[bool] = None) -> DrapeResult:
        """Dress the garment: close the seams with gravity off, then settle under gravity.

        Stages, each reported in the result:
        "sew" (skipped when settings.sew_first is False or there are no seams):
            gravity off, until the residual is below settings.sew_stage_tolerance
            or the largest seam gap below settings.sew_stage_gap_mm;
        "settle": gravity on, to settings.tolerance; with the Chebyshev method it
            stops early when the residual stagnates (no 30 % gain over two chunks
            of settings.chunk iterations);
        "polish" (Chebyshev only, settings.polish): Newton from where the settle
            stage stopped, when it stopped above the tolerance; on the GPU its
            steps are solved by MINRES there (inexact Newton, docs/gpu_backend.md).
        progress(iteration, residual) is called every settings.progress_every
        iterations, counting over all stages; returning False cancels (reported
        in the result, never raised).
        device: "cpu" or "cuda" (default settings.device).
        sewn: x0 is already a sewn garment on the body (a drape carried from a
            coarser mesh): no sew stage, whatever gaps interpolation left.
        polish: overrides settings.polish for this call.
        """
        s = self.settings
        x = self._start(x0)
        stages: list[dict] = []
        offset = [0]

        def relay(it, res):
            return True if progress is None else progress(offset[0] + it, res)

        def seams_closed(xx):
            return float(np.max(self.sewing_gaps(xx))) * 1000.0 <= s.sew_stage_gap_mm

        # A start that is already sewn (a drape carried over from a coarser
        # mesh) goes straight to the settle: gravity off would let it float.
        if s.sew_first and self._core.n_sewing > 0 and not sewn and not seams_closed(x):
            x, rep = self._staged(x, "sew", s.method, s.sew_stage_tolerance, None, relay, offset,
                                  gravity_scale=0.0, done=seams_closed, device=device)
            stages.append(rep)
            if rep["cancelled"]:
                return self._result(x, stages)
        x, rep = self._staged(x, "settle", s.method, s.tolerance, None, relay, offset,
                              stagnation=s.method == "chebyshev", device=device)
        stages.append(rep)
        do_polish = s.polish if polish is None else polish
        if (s.method == "chebyshev" and do_polish and not rep["converged"] and not rep["cancelled"]
                and s.polish_iterations > 0):
            x, rep = self._staged(x, "polish", "newton", s.tolerance, s.polish_iterations, relay, offset,
                                  smoothing=s.polish_smoothing, device=device)
            stages.append(rep)
        return self._result(x, stages)

    def polish(self, x, progress: Optional[Callable[[int, float], bool]] = None,
               device: Optional[str] = None) -> DrapeResult:
        """The drape's polish stage alone (Newton with block-Jacobi sweeps) from x,
        on `device` (default settings.device)."""
        s = self.settings
        x, rep = self._staged(self._start(x), "polish", "newton", s.tolerance, s.polish_iterations,
                              (lambda it, res: True) if progress is None else progress, [0],
                              smoothing=s.polish_smoothing, device=device)
        return self._result(x, [rep])

    def _staged(self, x, stage, method, tolerance, max_iterations, relay, offset, gravity_scale=1.0,
                done=None, stagnation=False, smoothing=0, device=None):
        """One stage, run in chunks (Chebyshev) so it can stop on a condition
        between chunks; the chunk reports are merged into one."""
        s = self.settings
        if max_iterations is None:
            max_iterations = s.newton_max_iterations if method == "newton" else s.max_iterations
        chunk = max(int(s.chunk), 1) if method == "chebyshev" else max_iterations
        merged = None
        t_start = time.perf_counter()
        best = [math.inf]
        since_best = 0
        # the chunk end of least residual: a stagnated Chebyshev run can stop
        # mid-oscillation, far above where it has been
        end_best = (math.inf, None)
        self._apply_params(gravity_scale=gravity_scale)
        try:
            total = 0
            while True:
                n = min(chunk, max(max_iterations - total, 0))
                left = 0.0
                if s.max_seconds > 0:
                    left = max(s.max_seconds - (time.perf_counter() - t_start), 1e-3)
                st = self._settings(tolerance, n, method, left, smoothing)
                x, rep = self._run(x, st, relay, device)
                total += rep["iterations"]
                offset[0] += rep["iterations"]
                merged = self._merge(merged, rep, stage)
                if rep["converged"] or rep["cancelled"] or total >= max_iterations or n == 0:
                    break
                if not rep["message"].startswith("not converged") or "iteration budget" not in rep["message"]:
                    break  # time budget, line search failure, non-finite state: stop the stage
                if done is not None and done(x):
                    merged["message"] = f"stopped: seams closed, relative residual {rep['residual']:.3g}"
                    break
                if stagnation:
                    if rep["residual"] < end_best[0]:
                        end_best = (rep["residual"], x.copy())
                    # the residual oscillates under momentum: judge a chunk by its best value
                    chunk_best = min(list(rep["history_residual"]) + [rep["residual"]])
                    if chunk_best < 0.7 * best[0]:
                        best[0] = chunk_best
                        since_best = 0
                    else:
                        since_best += 1
                        if since_best >= 2:
                            if end_best[0] < rep["residual"]:
                                x = end_best[1]
                                merged["residual"] = end_best[0]
                            merged["message"] = (f"stopped: relative residual stagnated at {merged['residual']:.3g} "
                                                 f"(> {tolerance:g}) after {total} iterations")
                            break
        finally:
            self._apply_params()
        return x, merged

    @staticmethod
    def _merge(merged, rep, stage):
        rep = dict(rep, stage=stage)
        if merged is None:
            return rep
        out = dict(rep)
        for k in ("iterations", "seconds", "restarts", "projections", "rejected_steps", "linear_iterations"):
            out[k] = merged.get(k, 0) + rep.get(k, 0)
        it0, t0 = merged["iterations"], merged["seconds"]
        out["history_iteration"] = list(merged["history_iteration"]) + [it0 + i for i in rep["history_iteration"]]
        out["history_seconds"] = list(merged["history_seconds"]) + [t0 + t for t in rep["history_seconds"]]
        out["history_residual"] = list(merged["history_residual"]) + list(rep["history_residual"])
        if rep["message"].startswith("not converged"):
            out["message"] = (f"not converged: relative residual {rep['residual']:.3g} after "
                              f"{out['iterations']} iterations" + (" (iteration budget)" if "iteration budget" in
                                                                  rep["message"] else ""))
        elif rep["converged"]:
            out["message"] = f"converged: relative residual {rep['residual']:.3g} after {out['iterations']} iterations"
        return out

    def _start(self, x0) -> np.ndarray:
        if x0 is None:
            if self.x0 is None:
                raise SolveError("no start positions: the mesh has no x0 and none was given")
            x0 = self.x0
        x = np.array(x0, dtype=np.float64).reshape(-1, 3)
        if len(x) != self.n_vertices:
            raise SolveError(f"start positions have {len(x)} rows for {self.n_vertices} vertices")
        if not np.all(np.isfinite(x)):
            raise SolveError("start positions contain non-finite values")
        return x

    def _result(self, x: np.ndarray, stages: list[dict]) -> DrapeResult:
        last = stages[-1]
        e, terms = self._host_model().energy(x)
        gaps = self.sewing_gaps(x)
        phi = self.phi(x) if self._core.has_sdf else np.array([np.inf])
        hist = {"iteration": [], "seconds": [], "residual": []}
        it0, t0 = 0, 0.0
        for s in stages:
            hist["iteration"] += [it0 + i for i in s["history_iteration"]]
            hist["seconds"] += [t0 + t for t in s["history_seconds"]]
            hist["residual"] += list(s["history_residual"])
            it0 += s["iterations"]
            t0 += s["seconds"]
        if not np.all(np.isfinite(x)):
            raise SolveError("internal error: the solver produced non-finite positions")
        msg = "; ".join(f"{s['stage']}: {s['message']}" for s in stages)
        return DrapeResult(
            x=x, iterations=int(sum(s["iterations"] for s in stages)),
            seconds=float(sum(s["seconds"] for s in stages)), residual=float(last["residual"]),
            converged=bool(last["converged"]), cancelled=bool(any(s["cancelled"] for s in stages)),
            message=msg, max_sewing_gap_mm=float(gaps.max() * 1000.0) if len(gaps) else 0.0,
            min_phi_mm=float(phi.min() * 1000.0), energy_terms=dict(terms),
            stages=stages, history=hist)
