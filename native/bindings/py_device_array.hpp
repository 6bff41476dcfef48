// DeviceArray arguments of the CUDA bindings: shape checks with the argument's name.
#pragma once
#ifdef SEAMFIT_WITH_CUDA
#include <pybind11/pybind11.h>

#include <string>

#include "device/device_array.hpp"

namespace seamfit::bindings {

inline void require_shape(const seamfit::cuda::DeviceArray& a, int rows, int cols, const char* name) {
  if (a.rows() != rows || a.cols() != cols)
    throw pybind11::value_error(std::string(name) + " must have shape (" + std::to_string(rows) + ", " +
                                std::to_string(cols) + "), got (" + std::to_string(a.rows()) + ", " +
                                std::to_string(a.cols()) + ")");
}

}  // namespace seamfit::bindings
#endif
