// Newton's method for a drape with its linear solves on the GPU: the CPU's
// Newton loop (line search, barrier-safe steps, smoothing; sim/solvers.cpp)
// with each step H_psd dx = f solved inexactly by the adjoint's preconditioned
// MINRES (adjoint_gpu.hpp) instead of a sparse LDL^T. The direct factorization
// is what stops the drape's polish at 60K triangles (minutes per step on the
// CPU); the step here costs a few thousand stored-block products on the GPU.
// Host-only interface: no CUDA types.
#pragma once
#include <atomic>

#include "sim/adjoint_gpu.hpp"
#include "sim/sim_gpu.hpp"
#include "sim/simulator.hpp"

namespace seamfit::cuda {

// x (3n) in and out. `gpu` must mirror `sim` (synced) and `lin` belong to
// `gpu`. s.method is taken as Newton whatever it says.
// max_linear_iterations: MINRES budget of one step (a truncated step is still used).
sim::SolveReport newton_on_gpu(sim::Simulator& sim, SimGpu& gpu, AdjointGpu& lin, double* x,
                               const sim::SolveSettings& s, const sim::ProgressFn& progress,
                               const std::atomic<bool>* cancel, int max_linear_iterations);

}  // namespace seamfit::cuda
