// The matrix-free product (df/dp)^T lam of the adjoint gradient on the GPU,
// from the same host-device pieces as the CPU's Simulator::dfdp_T
// (sim/dfdp.hpp): per spring, hinge, vertex and triangle, then a per-vertex
// gather in a fixed order. Host-only interface: no CUDA types.
#pragma once
#include <memory>

#include "sim/sim_gpu.hpp"

namespace seamfit::cuda {

class DfdpGpu {
 public:
  // `gpu` must outlive this object (its body field and stream are used).
  explicit DfdpGpu(SimGpu& gpu);
  ~DfdpGpu();
  DfdpGpu(const DfdpGpu&) = delete;
  DfdpGpu& operator=(const DfdpGpu&) = delete;

  // out (2n) = (df/dp)^T lam at x (3n), for the simulator's current pattern,
  // rest state and parameters (read from the CPU simulator at each call; the
  // body field is the GPU simulator's, so sync() it after a new body).
  void apply(const double* x, const double* lam, double* out);
  // The same with x, lam (3n) and out (2n) in device memory.
  void apply_device(const double* d_x, const double* d_lam, double* d_out);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
