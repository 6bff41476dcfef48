// Python bindings of the GPU copies of the regularizers (CudaRegularizers,
// CudaSeamLength). CUDA builds only; a CudaError becomes seamfit.errors.DeviceError
// (bind_cuda_sim registers that translation).
#ifdef SEAMFIT_WITH_CUDA
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <memory>
#include <stdexcept>

#include "bindings.hpp"
#include "opt/regularizer_set.hpp"
#include "opt/regularizers_gpu.hpp"
#include "opt/seam_length.hpp"
#include "opt_args.hpp"
#include "py_device_array.hpp"

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using namespace opt_args;
using cuda::DeviceArray;
using cuda::RegularizersGpu;
using cuda::SeamLengthGpu;

auto make_regularizers_gpu(const opt::Regularizers& objective, opt::Regularizers& precond,
                           size_t max_bytes) {
  // std::invalid_argument reaches Python as ValueError through pybind11's own translation.
  return std::make_unique<RegularizersGpu>(objective, precond, max_bytes);
}

auto regularizers_gpu_evaluate(RegularizersGpu& g, const DArr& theta) {
  check_shape(theta, g.n_theta(), 2, "theta");
  DArr grad = new_array(g.n_theta(), 2);
  std::array<double, 2> t{};
  const double v = g.evaluate(as<Vec2>(theta), as_mut<Vec2>(grad), &t);
  return py::make_tuple(v, py::make_tuple(t[0], t[1]), grad);
}

auto regularizers_gpu_precondition(RegularizersGpu& g, const DArr& grad) {
  check_shape(grad, g.n_theta(), 2, "g");
  DArr out = new_array(g.n_theta(), 2);
  g.apply_preconditioner(as<Vec2>(grad), as_mut<Vec2>(out));
  return out;
}

auto regularizers_gpu_evaluate_device(RegularizersGpu& g, const DeviceArray& theta, DeviceArray& grad) {
  require_shape(theta, g.n_theta(), 2, "theta");
  require_shape(grad, g.n_theta(), 2, "grad");
  std::array<double, 2> t{};
  const double v = g.evaluate_device(theta.data(), grad.data(), &t);
  return py::make_tuple(v, py::make_tuple(t[0], t[1]));
}

void regularizers_gpu_precondition_device(RegularizersGpu& g, const DeviceArray& grad, DeviceArray& out) {
  require_shape(grad, g.n_theta(), 2, "g");
  require_shape(out, g.n_theta(), 2, "out");
  g.apply_preconditioner_device(grad.data(), out.data());
}

// Binds CudaRegularizers, the GPU copy of Regularizers.
void bind_regularizers_gpu(py::module_& m) {
  py::class_<RegularizersGpu>(m, "CudaRegularizers",
                              "R^fix + R^cur and P^-1 g on the GPU (P^-1 dense, rebuilt when P changes).")
      .def(py::init(&make_regularizers_gpu), py::arg("objective"), py::arg("precond"), py::arg("max_bytes"),
           py::keep_alive<1, 2>(), py::keep_alive<1, 3>(),  // the CPU objects hold the strengths and P
           "GPU copies of `objective` and of `precond`'s P^-1 (at most max_bytes); both are kept alive.")
      .def_static("inverse_bytes", &RegularizersGpu::inverse_bytes, py::arg("n_theta"),
                  "device bytes of P^-1 for n_theta boundary entries")
      .def("evaluate", &regularizers_gpu_evaluate, py::arg("theta"),
           "-> (value, (R_fix, R_cur), gradient), as Regularizers.evaluate")
      .def("apply_preconditioner", &regularizers_gpu_precondition, py::arg("g"), "P^-1 g")
      .def("evaluate_device", &regularizers_gpu_evaluate_device, py::arg("theta"), py::arg("grad"),
           "-> (value, (R_fix, R_cur)); the gradient into grad (DeviceArrays)")
      .def("apply_preconditioner_device", &regularizers_gpu_precondition_device, py::arg("g"), py::arg("out"),
           "out = P^-1 g (DeviceArrays)")
      .def_property_readonly("device_bytes", &RegularizersGpu::device_bytes, "device memory held (bytes)")
      .def_property_readonly("inverse_builds", &RegularizersGpu::inverse_builds, "times P^-1 was rebuilt");
}

auto seam_gpu_evaluate(SeamLengthGpu& g, const DArr& theta) {
  check_shape(theta, g.n_theta(), 2, "theta");
  DArr grad = new_array(g.n_theta(), 2);
  const double v = g.evaluate(as<Vec2>(theta), as_mut<Vec2>(grad));
  return py::make_tuple(v, grad);
}

// Binds CudaSeamLength, the GPU copy of SeamLength.
void bind_seam_length_gpu(py::module_& m) {
  py::class_<SeamLengthGpu>(m, "CudaSeamLength", "R^seam and its gradient on the GPU, mirroring a SeamLength.")
      .def(py::init([](const opt::SeamLength& s) { return std::make_unique<SeamLengthGpu>(s); }), py::arg("seam"),
           py::keep_alive<1, 2>(),  // the CPU object holds the strength and the evaluation count
           "A GPU copy of `seam`, which it keeps alive.")
      .def("evaluate", &seam_gpu_evaluate, py::arg("theta"), "-> (value, gradient), as SeamLength.evaluate")
      .def(
          "evaluate_device",
          [](SeamLengthGpu& g, const DeviceArray& theta, DeviceArray& grad) {
            require_shape(theta, g.n_theta(), 2, "theta");
            require_shape(grad, g.n_theta(), 2, "grad");
            return g.evaluate_device(theta.data(), grad.data());
          },
          py::arg("theta"), py::arg("grad"), "-> value; the gradient into grad (DeviceArrays)");
}

}  // namespace

// Binds the GPU copies of the regularizers over theta.
void bind_opt_cuda(py::module_& m) {
  bind_regularizers_gpu(m);
  bind_seam_length_gpu(m);
}

}  // namespace seamfit::bindings
#endif
