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

// {name: value} per registered term, in registry order (opt/cost_terms.hpp).
template <class V>
pybind11::dict cost_terms_dict(const std::array<V, opt::kNumCostTerms>& t) {
  pybind11::dict d;
  for (int q = 0; q < opt::kNumCostTerms; ++q) d[opt::kCostTerms[q].name] = t[q];
  return d;
}

}  // namespace seamfit::bindings
