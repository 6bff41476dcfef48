// The boundary terms of the objective on the GPU: R^fix + R^cur (Eq. 9-10) and the
// seam-length term R^seam with their gradients, and the preconditioner P^-1 g (Section 7).
// The element functions are the CPU's (opt/costs/regularizers.hpp, seam_length.hpp):
// per element a value and gradient slots, per theta entry a gather in slot order, the
// values summed as block partials in a fixed order (the same result on every call).
// P is constant, SPD and boundary-sized, so P^-1 is computed once on the host from the
// CPU's Cholesky factorization (opt::Regularizers::dense_inverse) and each application
// is one dense symmetric matrix-vector product, one warp per row (dense_rows.cuh):
// bandwidth-bound, where the two sparse triangular solves of the factorization would run
// level by level. The CPU objects keep the strengths; P^-1 is rebuilt when P changes.
// The *_device entry points take float64 device arrays in the host layout (outputs
// must not overlap inputs) and return with their outputs complete.
// Host-only interface: no CUDA types.
#pragma once
#include <array>
#include <cstddef>
#include <memory>

#include "opt/regularizer_set.hpp"
#include "opt/seam_length.hpp"

namespace seamfit::cuda {

class RegularizersGpu {
 public:
  // objective: the terms of f (its strengths are read at each call); precond: the
  // instance whose P is applied (the same one unless f's R^fix differs from P's,
  // seamfit.opt.regularizers). Both must outlive this. Throws CudaError when P^-1,
  // 8 (2 n_theta)^2 bytes, would need more than max_bytes of device memory or more than
  // half of what is free (the caller stays on the CPU then).
  RegularizersGpu(const opt::Regularizers& objective, opt::Regularizers& precond, size_t max_bytes);
  ~RegularizersGpu();
  RegularizersGpu(const RegularizersGpu&) = delete;
  RegularizersGpu& operator=(const RegularizersGpu&) = delete;

  // As opt::Regularizers::evaluate, host arrays in and out.
  double evaluate(const Vec2* theta, Vec2* grad, std::array<double, 2>* terms);
  // P^-1 g; P^-1 is (re)built first when precond's P changed since the last call.
  void apply_preconditioner(const Vec2* g, Vec2* out);
  // As evaluate on device arrays: d_theta (n_theta, 2) in, d_grad (n_theta, 2) out.
  double evaluate_device(const double* d_theta, double* d_grad, std::array<double, 2>* terms);
  // As apply_preconditioner on device arrays: d_g (n_theta, 2) in, d_out (n_theta, 2) out.
  void apply_preconditioner_device(const double* d_g, double* d_out);
  // Bytes P^-1 takes on the device for n_theta boundary entries.
  static size_t inverse_bytes(int n_theta) { return 8 * size_t(2 * n_theta) * size_t(2 * n_theta); }
  size_t device_bytes() const;
  int n_theta() const;
  // How many times P^-1 was built (tests: rebuilt only when P changes).
  long inverse_builds() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

class SeamLengthGpu {
 public:
  // seam must outlive this; its strength is read at each call and its evaluation counter
  // counts the GPU's evaluations too.
  explicit SeamLengthGpu(const opt::SeamLength& seam);
  ~SeamLengthGpu();
  SeamLengthGpu(const SeamLengthGpu&) = delete;
  SeamLengthGpu& operator=(const SeamLengthGpu&) = delete;

  // As opt::SeamLength::evaluate.
  double evaluate(const Vec2* theta, Vec2* grad);
  // As evaluate on device arrays: d_theta (n_theta, 2) in, d_grad (n_theta, 2) out.
  double evaluate_device(const double* d_theta, double* d_grad);
  int n_theta() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
