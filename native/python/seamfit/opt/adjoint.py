"""The pattern gradient through the quasistatic equilibrium (paper Eq. 18-19).

At equilibrium f(p, x) = 0 with f = -dE/dx, so dx/dp = H^-1 df/dp where H = d2E/dx2
is the tangent stiffness. For a cost F(x, p) the adjoint method needs one linear
solve per gradient:

    H lam = dF/dx,        dF/dp (total) = dF/dp + (df/dp)^T lam,

and the product (df/dp)^T lam is matrix-free (Simulator.dfdp_T).

Keeping H solvable (docs/method.md, "Adjoint"): H is singular along motions the
model does not resist (a skirt turning about a frictionless body) and may be
indefinite away from equilibrium (compressed springs buckle sideways). The implicit
function theorem needs H invertible, not definite, so we factorize the EXACT Hessian
with a tiny Tikhonov shift eps * mean|diag H| * I (eps = 1e-8) that only pins the free
modes, by sparse LDL^T with an AMD ordering analysed once per mesh (the native
TangentSolver); where a pivot vanishes there, by SciPy's sparse LU (SuperLU, COLAMD),
which pivots. The LDL^T is about 3x faster (0.37 against 1.07 s with 16K unknowns). The PSD-projected Hessian (springs and hinges clamped to their
positive part) is available but not the default: on a hanging panel with compressed
springs it gave gradients off by up to 4x, against < 0.1 % for the exact one
(tests/opt/test_grade_gradient.py).

On the GPU (device "cuda") the same shifted system is solved iteratively instead
(seamfit._core.CudaAdjoint): preconditioned MINRES, which needs symmetry but not
definiteness, with the PSD diagonal blocks as its block-Jacobi preconditioner,
warm-started from the previous outer iteration's lam. A direct factorization does
not scale (0.34 s at 10K triangles, 3.0 s at 30K on one core) and does not map to
the GPU; the iterative solve keeps its vectors on the device.

Where MINRES does not reach its tolerance within its budget: at an equilibrium state
(residual within `equilibrium_tolerance`) it goes on from its last iterate, up to
GPU_EQUILIBRIUM_BUDGET_FACTOR budgets in all (counted in `extended`), and only then does
the gradient fall back to the CPU's factorization (counted in `gpu_fallbacks`); at an inexact state of the search (far
from equilibrium, where H is indefinite with eigenvalues of both signs within 1e-6 of
its scale, so that the direct solve's lam is dominated by those near-singular modes
and the implicit-function gradient does not hold anyway) MINRES's last iterate, the
minimum-residual solution in its Krylov space, is kept (counted in `truncated`).
docs/gpu_backend.md, "The adjoint on the GPU", has the measurements behind this.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._native import core
from ..device import require_device
from ..errors import SolveError
from ..device_arrays import Buffers, all_finite, host, is_device

DEFAULT_SHIFT = 1e-8
# MINRES on the GPU: |r|_{M^-1} <= tol |g|_{M^-1}; docs/gpu_backend.md has the gradient error
# against the direct solve at each tolerance.
GPU_TOLERANCE = 1e-8
GPU_MAX_ITERATIONS = 10000
# At an equilibrium state a solve stopped by the budget goes on from where it stopped, up to
# this many times the budget in all, before the CPU's factorization (seconds at 60K
# triangles, against 0.2 s per 10,000 MINRES iterations).
GPU_EQUILIBRIUM_BUDGET_FACTOR = 4


class AdjointSolver:
    """Factorizes the (projected, shifted) tangent stiffness at x and solves H lam = g."""

    def __init__(self, simulator, *, psd: bool = False, shift: float = DEFAULT_SHIFT, device: str = "cpu",
                 gpu_tolerance: float = GPU_TOLERANCE, gpu_max_iterations: int = GPU_MAX_ITERATIONS,
                 equilibrium_tolerance: float | None = None, inexact_forcing: float = 0.0):
        require_device(device, "the adjoint", SolveError, runnable=False)   # cuda is checked where it is used
        self.sim = simulator
        self.psd = psd
        self.shift = shift
        self.device = device
        self.gpu_tolerance = gpu_tolerance
        self.gpu_max_iterations = gpu_max_iterations
        # None: every unconverged GPU solve falls back to the CPU.
        self.equilibrium_tolerance = equilibrium_tolerance
        # > 0: at an inexact state (residual r above equilibrium_tolerance) MINRES stops at
        # max(gpu_tolerance, inexact_forcing * r), as inexact Newton does (0: always gpu_tolerance).
        self.inexact_forcing = float(inexact_forcing)
        self.relaxed = 0               # GPU solves at inexact states with the relaxed tolerance
        self.truncated = 0             # GPU solves at inexact states kept at MINRES's budget
        self.extended = 0              # GPU solves at equilibrium states continued past the budget
        self._solve = None
        self.factorizations = 0
        self.seconds_factorize = 0.0   # Hessian assembly and factorization (GPU: block setup), summed
        self.seconds_solve = 0.0       # the solves, summed
        self.lu_fallbacks = 0          # factorizations that needed the pivoting LU
        self.gpu_fallbacks = 0         # GPU solves that did not converge and were redone on the CPU
        self.minres_iterations = 0     # summed over the GPU solves
        self.solves = 0
        self.last_report: dict | None = None
        self._ldlt = None
        self._gpu_adjoint = None
        self._x = None                 # the state set on the GPU
        self._x_residual = None        # its relative residual, when the caller knew it
        self._lam = None               # the last lam: the next GPU solve's start (NumPy or DeviceArray)
        self._out = Buffers()          # DeviceArray lam

    def stats(self) -> dict:
        d = {"device": self.device, "factorizations": self.factorizations, "lu_fallbacks": self.lu_fallbacks,
             "solves": self.solves, "seconds_factorize": self.seconds_factorize,
             "seconds_solve": self.seconds_solve}
        if self.device == "cuda":
            d.update(minres_iterations=self.minres_iterations, gpu_fallbacks=self.gpu_fallbacks,
                     truncated=self.truncated, extended=self.extended, tolerance=self.gpu_tolerance,
                     max_iterations=self.gpu_max_iterations, inexact_forcing=self.inexact_forcing,
                     relaxed=self.relaxed)
        return d

    def factorize(self, x, residual: float | None = None) -> None:
        """Prepare solves at the garment state x; `residual`: x's relative residual
        if known (the GPU solve's tolerance and fallback rule use it). x may be a
        DeviceArray (device "cuda": the state stays on the GPU)."""
        self._x_residual = residual
        t0 = time.perf_counter()
        try:
            if self.device == "cuda":
                self._set_gpu_state(x if is_device(x) else np.asarray(x, dtype=np.float64).reshape(-1, 3))
            else:
                self._factorize(np.asarray(host(x), dtype=np.float64))
        finally:
            self.seconds_factorize += time.perf_counter() - t0

    def _gpu(self):
        if self._gpu_adjoint is None:
            gpu = self.sim.cuda()
            self._gpu_adjoint = core().CudaAdjoint(gpu._gpu)
        return self._gpu_adjoint

    def _set_gpu_state(self, x) -> None:
        gpu = self.sim.cuda()
        gpu.sync()  # the pattern (rest state) may have changed since the last simulation
        if is_device(x):
            self._gpu().set_state_device(gpu._gpu, x, self.psd, self.shift)
        else:
            self._gpu().set_state(gpu._gpu, x, self.psd, self.shift)
        # A DeviceArray is kept by reference: it stays unchanged until the gradient that
        # set it is done (the fallback and the residual read it then).
        self._x = x if is_device(x) else x.copy()
        self._solve = self._solve_gpu
        self.factorizations += 1

    def _solve_gpu(self, g) -> np.ndarray:
        gpu = self.sim.cuda()
        dev = is_device(g)
        if dev:
            # The warm start stays on the GPU too (uploaded once if it came from the host).
            lam = self._out.get("lam", g.shape[0], 3)
            if isinstance(self._lam, np.ndarray) and self._lam.shape == tuple(g.shape):
                lam.upload(self._lam)
            elif self._lam is not lam:
                lam.upload(np.zeros(tuple(g.shape)))

            def minres(budget):
                return self._gpu().solve_device(gpu._gpu, g, lam, tol, budget)
        else:
            g = np.ascontiguousarray(g, dtype=np.float64).reshape(-1, 3)
            lam = host(self._lam) if self._lam is not None and tuple(self._lam.shape) == g.shape else None

            def minres(budget):
                nonlocal lam
                lam, rep = self._gpu().solve(gpu._gpu, g, lam, tol, budget)
                return rep
        residual = None
        if self.equilibrium_tolerance is not None:
            residual = self._x_residual if self._x_residual is not None else gpu.residual(host(self._x))
        inexact = residual is not None and residual > self.equilibrium_tolerance
        tol = self.gpu_tolerance
        if inexact and self.inexact_forcing > 0:
            tol = max(tol, self.inexact_forcing * residual)
            self.relaxed += 1
        rep = minres(self.gpu_max_iterations)
        self.minres_iterations += int(rep["iterations"])
        more = (GPU_EQUILIBRIUM_BUDGET_FACTOR - 1) * self.gpu_max_iterations
        if (not rep["converged"] and rep["status"] == "budget" and not inexact and more > 0
                and all_finite(lam)):
            # MINRES restarted from its last iterate: the same tolerance on the same system.
            rep = minres(more)
            self.minres_iterations += int(rep["iterations"])
            self.extended += 1
        self.last_report = rep
        finite = all_finite(lam)
        if not rep["converged"] and finite and rep["status"] == "budget" and inexact:
            self.truncated += 1
        elif not rep["converged"] or not finite:
            # The direct solve is exact and robust; it costs a factorization (of the CPU
            # model, so a pattern set on the GPU alone goes to it first).
            self.gpu_fallbacks += 1
            self.sim.sync_host_pattern()
            self._factorize(np.asarray(host(self._x), dtype=np.float64))  # timed within this solve
            lam_h = np.asarray(self._solve(host(g).reshape(-1))).reshape(-1, 3)
            self._solve = self._solve_gpu
            if dev:
                lam.upload(lam_h)
            else:
                lam = lam_h
        self._lam = lam
        return lam if dev else lam.reshape(-1)

    def _factorize(self, x) -> None:
        if self._ldlt is None:
            self._ldlt = core().TangentSolver(self.sim.core)
        if self._ldlt.factorize(x, self.psd, self.shift):
            self._solve = self._ldlt.solve
            self.factorizations += 1
            return
        # A vanishing LDL^T pivot (no pivoting there): LU with partial pivoting.
        H = self.sim.hessian(x, psd=self.psd).tocsc()
        diag = H.diagonal()
        scale = float(np.mean(np.abs(diag))) if len(diag) else 1.0
        if not np.isfinite(scale) or scale <= 0:
            raise SolveError("the tangent stiffness is not finite at this garment state")
        H = H + sp.identity(H.shape[0], format="csc") * (self.shift * scale)
        try:
            self._solve = spla.factorized(H)
        except RuntimeError as exc:  # SuperLU reports an exactly singular matrix
            raise SolveError(f"the tangent stiffness could not be factorized: {exc}") from exc
        self.factorizations += 1
        self.lu_fallbacks += 1

    def solve(self, g) -> np.ndarray:
        """lam with H lam = g; a DeviceArray g (device "cuda") gives a DeviceArray lam,
        this solver's buffer, which is also the next solve's warm start."""
        if self._solve is None:
            raise SolveError("AdjointSolver.solve called before factorize")
        # Name the input that is not finite: a bad right-hand side or garment state is a
        # different defect from a solver breakdown.
        if not all_finite(g):
            raise SolveError("the adjoint solve was given a non-finite cost gradient dF/dx")
        if self._x is not None and not all_finite(self._x):
            raise SolveError("the adjoint solve was given a non-finite garment state x")
        t0 = time.perf_counter()
        if is_device(g) and self._solve == self._solve_gpu:
            lam = self._solve_gpu(g)
        else:
            lam = np.asarray(self._solve(np.ascontiguousarray(host(g), dtype=float).reshape(-1)))
        self.seconds_solve += time.perf_counter() - t0
        self.solves += 1
        if not all_finite(lam):
            raise SolveError("the adjoint solve produced non-finite values")
        return lam

    def pattern_gradient(self, x, grad_x, grad_p, *, refactor: bool = True,
                         residual: float | None = None) -> np.ndarray:
        """Total dF/dp (N, 2) from the partials dF/dx (N, 3) and dF/dp (N, 2);
        `residual`: x's relative residual, if known."""
        if refactor or self._solve is None:
            self.factorize(x, residual)
        lam = self.solve(grad_x)
        if is_device(x):
            # All on the GPU: the product into its buffer, then grad_p added there.
            if not is_device(lam):
                lam = self._out.put("lam_host", np.reshape(lam, (-1, 3)))
            out = self.sim.cuda().dfdp_T(x, lam)
            out.axpy(1.0, grad_p)
            return out
        # On the GPU the product runs there too (the rest state is read at each call).
        dfdp = self.sim.cuda().dfdp_T if self.device == "cuda" else self.sim.dfdp_T
        return np.asarray(grad_p, dtype=float).reshape(-1, 2) + dfdp(x, lam.reshape(-1, 3))
