// The pattern parametrization p(theta) (paper Eq. 8) and its adjoint on the GPU.
// The interior update p^I = pbar^I - (L^I)^-1 L^B (theta - theta_bar) is linear
// with a constant matrix (the base pattern's Laplacian), so it is precomputed once
// as dense blocks, one per panel (opt::Parametrization::harmonic_blocks), and each
// call is a dense matrix-vector product: bandwidth-bound, a fraction of a
// millisecond at 60K triangles, against two sparse triangular solves on the CPU.
// The blocks and their transposes (for the adjoint) stay in device memory. The
// *_device entry points take float64 device arrays in the host layout (outputs must
// not overlap inputs) and return with their outputs complete.
// Host-only interface: no CUDA types.
#pragma once
#include <cstddef>
#include <memory>

#include "opt/parametrization.hpp"

namespace seamfit::cuda {

class PatternGpu {
 public:
  // Throws CudaError when the blocks would need more than max_bytes of device
  // memory or more than half of what is free (the caller stays on the CPU then).
  PatternGpu(const opt::Parametrization& param, size_t max_bytes);
  ~PatternGpu();
  PatternGpu(const PatternGpu&) = delete;
  PatternGpu& operator=(const PatternGpu&) = delete;

  // As opt::Parametrization::pattern / adjoint, host arrays in and out.
  void pattern(const Vec2* theta, Vec2* p);
  void adjoint(const Vec2* g, Vec2* g_theta);
  // As pattern on device arrays: d_theta (n_theta, 2) in, d_p (n, 2) out.
  void pattern_device(const double* d_theta, double* d_p);
  // As adjoint on device arrays: d_g (n, 2) in, d_g_theta (n_theta, 2) out.
  void adjoint_device(const double* d_g, double* d_g_theta);
  size_t device_bytes() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
