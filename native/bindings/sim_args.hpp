// Argument checks and array conversions shared by the CPU simulator's bindings
// (sim.cpp, sim_solvers.cpp). Failures raise SimError, which bind_sim maps to
// seamfit.errors.SolveError.
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/simulator.hpp"

namespace seamfit::bindings::sim_args {

namespace py = pybind11;

using sim::SimError;
using sim::Simulator;
using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IArr = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;
using FArr = py::array_t<float, py::array::c_style | py::array::forcecast>;

// cols > 0: shape (rows, cols); otherwise (rows,).
inline void require_shape(const py::array& a, py::ssize_t rows, py::ssize_t cols, const char* what) {
  const bool ok = cols > 0 ? (a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols)
                           : (a.ndim() == 1 && a.shape(0) == rows);
  if (!ok) {
    std::string want = cols > 0 ? "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")"
                                : "(" + std::to_string(rows) + ",)";
    throw sim::SimError(std::string(what) + " must have shape " + want);
  }
}

// The barrier is undefined inside the body, so force and Hessian refuse such states.
inline void require_outside(sim::Simulator& s, const double* x) {
  double phi = 0;
  const int v = s.first_inside(x, &phi);
  if (v >= 0)
    throw sim::SimError("vertex " + std::to_string(v) + " is inside the body (phi = " + std::to_string(phi * 1000.0) +
                        " mm): the barrier is undefined there; call project_outside first");
}

// A flat vector as a (size / cols, cols) array, or (size,) when cols <= 1.
template <class T>
py::array_t<T> vec_to_array(const std::vector<T>& v, py::ssize_t cols) {
  if (cols > 1) {
    py::array_t<T> a({py::ssize_t(v.size()) / cols, cols});
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
  }
  py::array_t<T> a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

}  // namespace seamfit::bindings::sim_args
