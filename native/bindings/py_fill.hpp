// New float64 arrays that a long C++ computation fills with the GIL released,
// shared by the simulator's and the optimizer's bindings.
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace seamfit::bindings {

// A new (rows, cols) array written by fill(data) while other Python threads run.
template <class Fill>
pybind11::array_t<double> fill_released(pybind11::ssize_t rows, pybind11::ssize_t cols, Fill&& fill) {
  pybind11::array_t<double> a({rows, cols});
  double* data = a.mutable_data();
  {
    pybind11::gil_scoped_release nogil;
    fill(data);
  }
  return a;
}

}  // namespace seamfit::bindings
