#include <omp.h>

#include "bindings.hpp"
#ifdef SEAMFIT_WITH_CUDA
#include "device/device_info.hpp"
#endif

namespace py = pybind11;

namespace seamfit::bindings {

// Binds the backend queries: CUDA build flag, CUDA devices, OpenMP threads.
void bind_device(py::module_& m) {
#ifdef SEAMFIT_WITH_CUDA
  m.attr("built_with_cuda") = true;
  m.def("cuda_device_count", &seamfit::cuda::device_count,
        "Number of usable CUDA devices (0 when no driver or GPU is present).");
  m.def("cuda_device_name", &seamfit::cuda::device_name, py::arg("index") = 0,
        "Name of CUDA device `index`, or an empty string.");
#else
  m.attr("built_with_cuda") = false;
  m.def("cuda_device_count", []() { return 0; }, "This build has no CUDA backend: always 0.");
  m.def("cuda_device_name", [](int) { return std::string(); }, py::arg("index") = 0,
        "This build has no CUDA backend: always an empty string.");
#endif
  m.def("omp_max_threads", []() { return omp_get_max_threads(); }, "OpenMP threads used by the CPU backend.");
}

}  // namespace seamfit::bindings
