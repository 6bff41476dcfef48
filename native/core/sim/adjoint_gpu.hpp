// The adjoint solve H lam = g of the pattern gradient (paper Eq. 18-19) on the
// GPU: preconditioned MINRES (sim/minres.hpp) over the exact (or PSD-projected)
// tangent stiffness H at a garment state x, plus the CPU solver's Tikhonov
// shift eps * mean|diag H|. The spring and vertex Hessian blocks are computed
// once per state and stored, so each iteration is a stored-block product (a
// gather, no atomics); the preconditioner is block Jacobi with the PSD
// diagonal blocks. Vectors stay on the device; the host looks in once per batch
// of iterations: one persistent cooperative kernel with two grid barriers
// per iteration, or (where cooperative launch is not available, or asked for)
// a CUDA graph of four kernels per iteration. Host-only interface: no CUDA types.
#pragma once
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "sim/sim_gpu.hpp"

namespace seamfit::cuda {

struct AdjointSettings {
  double tolerance = 1e-6;   // relative: |r|_{M^-1} <= tolerance * |g|_{M^-1}
  int max_iterations = 20000;
  int batch = 32;            // MINRES iterations per launch between host looks
  bool persistent = true;    // one cooperative kernel per batch (else a graph of four kernels per iteration)
};

struct AdjointReport {
  bool converged = false;
  std::string status;        // "converged", "budget" (iteration budget) or "breakdown"
  int iterations = 0;
  double residual = 0;       // true |g - H lam| / |g| at the returned lam
  double estimate = 0;       // MINRES's |r|_{M^-1} / |g|_{M^-1}
  double shift = 0;          // the diagonal shift used
  double seconds = 0;
  std::string message;
};

class AdjointGpu {
 public:
  // `gpu` must outlive this object; its model is read at each set_state.
  explicit AdjointGpu(SimGpu& gpu);
  ~AdjointGpu();
  AdjointGpu(const AdjointGpu&) = delete;
  AdjointGpu& operator=(const AdjointGpu&) = delete;

  // H at x (3n): exact or PSD-projected, shifted by shift_rel * mean|diag H|.
  void set_state(const double* x, bool psd, double shift_rel);
  // Solves H lam = g (3n); lam holds the start on entry (a warm start; zeros
  // for none) and the solution on return.
  AdjointReport solve(const double* g, double* lam, const AdjointSettings& s);
  // set_state and solve take host or device pointers alike; these names say the latter
  // (the search's state stays in device memory).
  void set_state_device(const double* d_x, bool psd, double shift_rel);
  AdjointReport solve_device(const double* d_g, double* d_lam, const AdjointSettings& s);

  struct Impl;

 private:
  AdjointReport minres(const AdjointSettings& s, std::chrono::steady_clock::time_point t0);  // from the uploaded g, lam
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
