// One registration function per domain; each lives in its own file and stays thin.
#pragma once
#include <pybind11/pybind11.h>

namespace seamfit::bindings {
void bind_device(pybind11::module_& m);
void bind_device_array(pybind11::module_& m);
void bind_body(pybind11::module_& m);
void bind_sim(pybind11::module_& m);
void bind_opt(pybind11::module_& m);
void bind_cuda_sim(pybind11::module_& m);
}  // namespace seamfit::bindings
