// Argument checks shared by the CUDA bindings (cuda_sim.cpp, cuda_adjoint.cpp):
// states sized to a GPU simulator, host (numpy) or device (DeviceArray). Failures
// raise SimError, which bind_sim maps to seamfit.errors.SolveError.
#pragma once
#ifdef SEAMFIT_WITH_CUDA
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "py_device_array.hpp"
#include "sim/sim_gpu.hpp"
#include "sim/simulator.hpp"

namespace seamfit::bindings::cuda_args {

namespace py = pybind11;

using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
using cuda::DeviceArray;
using cuda::SimGpu;
using sim::Simulator;
using sim::SolveReport;
using sim::SolveSettings;

// x: a host state (n, 3) of g's simulator.
inline void require_x(const SimGpu& g, const py::array& x) {
  const int n = g.simulator().n_vertices();
  if (x.ndim() != 2 || x.shape(0) != n || x.shape(1) != 3)
    throw sim::SimError("x must have shape (" + std::to_string(n) + ", 3)");
}

// The barrier is undefined inside the body, so force and Hessian refuse such states.
inline void require_outside(SimGpu& g, const double* x) {
  double phi = 0;
  const int v = g.first_inside(x, &phi);
  if (v >= 0)
    throw sim::SimError("vertex " + std::to_string(v) + " is inside the body (phi = " +
                        std::to_string(phi * 1000.0) +
                        " mm): the barrier is undefined there; call project_outside first");
}

// x: a device state (n, 3) of g's simulator.
inline void require_x(const SimGpu& g, const DeviceArray& x, const char* name = "x") {
  require_shape(x, g.simulator().n_vertices(), 3, name);
}

// As require_outside, for a state in device memory (the check runs there).
inline void require_outside_device(SimGpu& g, const DeviceArray& x) {
  const int v = g.first_unsafe_device(x.data(), 0.0);
  if (v >= 0)
    throw sim::SimError("vertex " + std::to_string(v) + " is inside the body or not finite: the barrier is undefined "
                        "there; call project_outside first");
}

}  // namespace seamfit::bindings::cuda_args
#endif
