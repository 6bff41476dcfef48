// The Python face of opt::CostSet, shared by the CPU binding (opt.cpp) and the
// CUDA cost set's (cuda_sim.cpp), which is built from it.
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <memory>

#include "opt/cost_set.hpp"

namespace seamfit::bindings {

// CostSet plus the arrays its non-owning SDF view points into.
struct PyCostSet {
  std::unique_ptr<opt::CostSet> cs;
  pybind11::array_t<float, pybind11::array::c_style | pybind11::array::forcecast> sdf_values;
};

inline pybind11::dict cost_terms_dict(const std::array<double, opt::kNumCostTerms>& t) {
  pybind11::dict d;
  d["dis"] = t[opt::kDistance];
  d["smo"] = t[opt::kSmoothness];
  d["str"] = t[opt::kStretching];
  d["pos"] = t[opt::kPositional];
  return d;
}

}  // namespace seamfit::bindings
