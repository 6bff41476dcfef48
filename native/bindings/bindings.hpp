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

// Sub-domains, each called by its domain's function above. The order of the calls
// is part of the module: pybind names a class in a signature only once it is bound.
void bind_sim_solvers(pybind11::module_& m);  // sim_solvers.cpp, from bind_sim
void bind_opt_costs(pybind11::module_& m);    // opt_costs.cpp, from bind_opt
void bind_opt_cuda(pybind11::module_& m);     // opt_cuda.cpp, from bind_opt (CUDA builds)
void bind_cuda_adjoint(pybind11::module_& m); // cuda_adjoint.cpp, from bind_cuda_sim (CUDA builds)
void bind_cuda_opt(pybind11::module_& m);     // cuda_opt.cpp, from bind_cuda_sim (CUDA builds)
}  // namespace seamfit::bindings
