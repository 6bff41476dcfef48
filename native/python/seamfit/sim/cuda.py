"""GPU (CUDA) backend of the quasistatic simulator.

``CudaSimulator(simulator)`` copies a built simulator (topology, rest state,
parameters, body SDF) to a CUDA device and runs its force, energy and the
Chebyshev-accelerated block-Jacobi solve there, with the CPU solver's rules and
the same energy functions (see docs/gpu_backend.md). The CPU simulator stays the owner
of the model: after changing it (parameters, pattern, shirring, sticking,
body) call ``sync()``, which ``solve`` does by default.

Without a usable GPU the constructor raises seamfit.errors.DeviceError saying why.
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from .._native import core
from ..device import require_device


class CudaSimulator:
    """GPU mirror of a simulator.

    simulator: a seamfit.sim.Simulator (its settings supply the solver
        controls) or a seamfit._core.Simulator.
    float_rest: store rest lengths, shirring, the bending matrix, masses and
        barrier weights as float32 (arithmetic stays float64); see docs/gpu_backend.md
        for what that costs in accuracy.
    batch: iterations per graph launch between two looks of the host (even).
    block, lanes: threads per block, and threads per vertex in the force
        evaluation (0: 2 while that keeps it in one wave of resident blocks, else 1);
        tuning, see docs/gpu_results.md.
    """

    def __init__(self, simulator, *, device: int = 0, batch: int = 32, block: int = 128, lanes: int = 0,
                 use_graph: bool = True, float_rest: bool = False):
        require_device("cuda", "the GPU simulator")
        self.simulator = simulator
        self._core_sim = simulator.core if hasattr(simulator, "core") else simulator
        self._gpu = core().CudaSimulator(self._core_sim, device=device, block=block, lanes=lanes, batch=batch,
                                         use_graph=use_graph, float_rest=float_rest)
        self._adjoint = None  # CudaAdjoint for Newton's steps, made on first use
        self._dfdp = None     # CudaDfdp, made on first use
        self.device_pattern_ahead = False  # a pattern set on the device alone, not yet on the CPU
        self._dfdp_out = None       # DeviceArray result of dfdp_T

    @property
    def device_name(self) -> str:
        return self._gpu.device_name

    @property
    def lanes(self) -> int:
        return self._gpu.lanes

    @property
    def device_bytes(self) -> int:
        return self._gpu.device_bytes

    def sync(self) -> None:
        """Bring the device up to the CPU simulator's model. Only what changed moves;
        a new pattern is uploaded and its rest state computed on the device (the CPU
        simulator computes its own only when a CPU method needs it)."""
        self._gpu.sync()

    def rest_state(self) -> dict:
        """The device's rest lengths, masses and weight norm (after a sync)."""
        return self._gpu.rest_state()

    def energy(self, x) -> tuple[float, dict[str, float]]:
        return self._gpu.energy(np.asarray(x, dtype=np.float64))

    def force(self, x) -> np.ndarray:
        """f = -dE/dx, shape (N, 3), evaluated on the GPU."""
        return self._gpu.force(np.asarray(x, dtype=np.float64))

    def hess_vec(self, x, v, psd: bool = False) -> np.ndarray:
        """(d2E/dx2) v, shape (N, 3), on the GPU (exact, or PSD-projected with psd);
        the product the adjoint's iterative solve is built on."""
        return self._gpu.hess_vec(np.asarray(x, dtype=np.float64), np.asarray(v, dtype=np.float64), bool(psd))

    def residual(self, x) -> float:
        return float(np.linalg.norm(self.force(x)) / self._gpu.weight_norm)

    def _settings(self, tolerance, max_iterations, method="chebyshev"):
        sim = self.simulator
        if hasattr(sim, "_settings"):
            return sim._settings(tolerance, max_iterations, method)
        st = core().SolveSettings()
        st.method = 1 if method == "newton" else 0
        if tolerance is not None:
            st.tolerance = float(tolerance)
        if max_iterations is not None:
            st.max_iterations = int(max_iterations)
        return st

    def solve(self, x0, tolerance: Optional[float] = None, max_iterations: Optional[int] = None, *,
              settings=None, progress: Optional[Callable[[int, float], bool]] = None,
              sync: bool = True) -> tuple[np.ndarray, dict]:
        """Chebyshev solve from x0 (N, 3) on the GPU: (x, report), the report
        with the keys of the CPU solve's (plus 'device').

        settings: a seamfit._core.SolveSettings (default: the simulator's, with
        tolerance / max_iterations overriding). progress(iteration, residual) is
        called between batches of iterations, at most once per
        settings.progress_every iterations; returning False cancels.
        """
        st = settings if settings is not None else self._settings(tolerance, max_iterations)
        if sync:
            self._gpu.sync()
        return self._gpu.solve(np.asarray(x0, dtype=np.float64).reshape(-1, 3), st, progress)

    def solve_device(self, x, *, settings, progress: Optional[Callable[[int, float], bool]] = None) -> dict:
        """The solve with x a DeviceArray (N, 3), advanced in place: the search's state
        stays on the GPU. Returns the report."""
        self._gpu.sync()
        return self._gpu.solve_device(x, settings, progress)

    def set_pattern_device(self, p) -> None:
        """A new pattern (DeviceArray (N, 2)) and its rest state on the GPU alone (the
        device keeps its own copy of p)."""
        self._gpu.set_pattern_device(p)
        self.device_pattern_ahead = True

    def take_device_pattern(self):
        """The pattern set on the GPU alone since the CPU simulator's last one (NumPy),
        or None; the caller hands it to the CPU simulator."""
        if not self.device_pattern_ahead:
            return None
        self.device_pattern_ahead = False
        return self._gpu.pattern()

    def dfdp_T(self, x, lam) -> np.ndarray:
        """(df/dp)^T lam, shape (N, 2), on the GPU: the adjoint gradient's matrix-free
        product, from the same element functions as Simulator.dfdp_T. With DeviceArrays
        x and lam the result is a DeviceArray (reused by the next call)."""
        if self._dfdp is None:
            self._dfdp = core().CudaDfdp(self._gpu)
        from ..device_arrays import is_device
        if is_device(x):
            if self._dfdp_out is None or self._dfdp_out.shape[0] != x.shape[0]:
                self._dfdp_out = core().DeviceArray.zeros(x.shape[0], 2)
            self._dfdp.apply_device(self._gpu, x, lam, self._dfdp_out)
            return self._dfdp_out
        return self._dfdp.apply(self._gpu, np.asarray(x, dtype=np.float64).reshape(-1, 3),
                                np.asarray(lam, dtype=np.float64).reshape(-1, 3))

    def newton(self, x0, *, settings=None, progress: Optional[Callable[[int, float], bool]] = None,
               max_linear_iterations: int = 5000, sync: bool = True) -> tuple[np.ndarray, dict]:
        """Newton from x0 (N, 3) with each step's linear system solved on the GPU
        by preconditioned MINRES (inexact Newton); the line search runs on the
        CPU. Returns (x, report) with the CPU Newton's keys, 'linear_iterations'
        (MINRES, all steps) and 'device'. max_linear_iterations: MINRES budget
        of one step; a step stopped there is still used."""
        st = settings if settings is not None else self._settings(None, None, "newton")
        if sync:
            self._gpu.sync()
        if self._adjoint is None:
            self._adjoint = core().CudaAdjoint(self._gpu)
        return self._gpu.newton(self._core_sim, self._adjoint, np.asarray(x0, dtype=np.float64).reshape(-1, 3), st,
                                progress, int(max_linear_iterations))

    def time_kernels(self, x, reps: int = 200) -> dict:
        """Device microseconds per kernel of an iteration at x, and the bytes each must move."""
        return self._gpu.time_kernels(np.asarray(x, dtype=np.float64), reps)
