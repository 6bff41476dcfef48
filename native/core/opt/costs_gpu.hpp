// The fitting costs of Section 6 (every term of opt/cost_terms.hpp) and their gradients on
// the GPU, from the same host-device element functions as the CPU's opt::CostSet
// (opt/costs/*.hpp) and the same slot gather. The constant data (elements, each term's
// constants, the target field) is copied from a CostSet once; strengths are read from it
// at each call, and a zero strength skips its term. evaluate_device takes float64 device
// arrays in the host layout (its outputs must not overlap its inputs) and returns with
// them complete. Host-only interface: no CUDA types.
#pragma once
#include <array>
#include <memory>

#include "opt/cost_set.hpp"

namespace seamfit::cuda {

class CostSetGpu {
 public:
  // `cs` must outlive this object; call again after its set_target_sdf / set_inputs.
  explicit CostSetGpu(opt::CostSet& cs);
  ~CostSetGpu();
  CostSetGpu(const CostSetGpu&) = delete;
  CostSetGpu& operator=(const CostSetGpu&) = delete;

  // As opt::CostSet::evaluate: total value, per-term values, gradients (n, 3), (n, 2).
  double evaluate(const double* x, const double* p, double* grad_x, double* grad_p,
                  opt::CostValues* terms);
  // As evaluate on device arrays: d_x (n, 3), d_p (n, 2) in; d_grad_x (n, 3), d_grad_p (n, 2) out.
  double evaluate_device(const double* d_x, const double* d_p, double* d_grad_x, double* d_grad_p,
                         opt::CostValues* terms);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
