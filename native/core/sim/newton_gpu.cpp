#include "sim/newton_gpu.hpp"

#include <algorithm>
#include <cmath>

namespace seamfit::cuda {

sim::SolveReport newton_on_gpu(sim::Simulator& sim, SimGpu& gpu, AdjointGpu& lin, double* x,
                               const sim::SolveSettings& s, const sim::ProgressFn& progress,
                               const std::atomic<bool>* cancel, int max_linear_iterations) {
  if (&gpu.simulator() != &sim) throw sim::SimError("newton_on_gpu: the GPU simulator mirrors another simulator");
  const int n3 = 3 * sim.n_vertices();
  sim::NewtonStepFn step = [&](const double* xs, bool psd, double shift_rel, const double* f, double forcing,
                               double* dx) -> int {
    lin.set_state(xs, psd, shift_rel);
    std::fill(dx, dx + n3, 0.0);
    AdjointSettings a;
    a.tolerance = forcing;
    a.max_iterations = std::max(1, max_linear_iterations);
    const AdjointReport r = lin.solve(f, dx, a);
    if (r.status == "breakdown") return -1;
    for (int i = 0; i < n3; ++i)
      if (!std::isfinite(dx[i])) return -1;
    return r.iterations;
  };
  sim::SolveSettings st = s;
  st.method = 1;
  return sim.solve(x, st, progress, cancel, step);
}

}  // namespace seamfit::cuda
