// Python bindings of the optimizer's GPU blocks that live beside the CUDA simulator:
// the pattern parametrization (CudaPattern) and the fitting costs (CudaCostSet).
// CUDA builds only.
#ifdef SEAMFIT_WITH_CUDA
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "opt/costs_gpu.hpp"
#include "opt/parametrization.hpp"
#include "opt/pattern_gpu.hpp"
#include "py_cost_set.hpp"
#include "py_device_array.hpp"

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using seamfit::cuda::CostSetGpu;
using seamfit::cuda::DeviceArray;
using seamfit::cuda::PatternGpu;
using seamfit::opt::Parametrization;
using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (rows_in, 2) -> (rows_out, 2) through fn with the GIL released: p(theta) and its adjoint.
template <class Fn>
py::array_t<double> pattern_map(const DArr& in, int rows_in, int rows_out, const char* name, Fn&& fn) {
  if (in.ndim() != 2 || in.shape(0) != rows_in || in.shape(1) != 2)
    throw py::value_error(std::string(name) + " must have shape (" + std::to_string(rows_in) + ", 2)");
  py::array_t<double> out({py::ssize_t(rows_out), py::ssize_t(2)});
  auto* op = reinterpret_cast<seamfit::Vec2*>(out.mutable_data());
  {
    py::gil_scoped_release nogil;
    fn(reinterpret_cast<const seamfit::Vec2*>(in.data()), op);
  }
  return out;
}

auto pattern_gpu_pattern(PatternGpu& g, const Parametrization& p, DArr theta) {
  return pattern_map(theta, p.n_boundary(), p.n_vertices(), "theta",
                     [&](const seamfit::Vec2* in, seamfit::Vec2* out) { g.pattern(in, out); });
}

auto pattern_gpu_adjoint(PatternGpu& g, const Parametrization& p, DArr grad) {
  return pattern_map(grad, p.n_vertices(), p.n_boundary(), "g",
                     [&](const seamfit::Vec2* in, seamfit::Vec2* out) { g.adjoint(in, out); });
}

void pattern_gpu_pattern_device(PatternGpu& g, const Parametrization& p, const DeviceArray& theta, DeviceArray& out) {
  require_shape(theta, p.n_boundary(), 2, "theta");
  require_shape(out, p.n_vertices(), 2, "p");
  py::gil_scoped_release nogil;
  g.pattern_device(theta.data(), out.data());
}

void pattern_gpu_adjoint_device(PatternGpu& g, const Parametrization& p, const DeviceArray& grad, DeviceArray& out) {
  require_shape(grad, p.n_vertices(), 2, "g");
  require_shape(out, p.n_boundary(), 2, "out");
  py::gil_scoped_release nogil;
  g.adjoint_device(grad.data(), out.data());
}

// Binds CudaPattern, p(theta) and its adjoint on the GPU.
void bind_pattern_gpu(py::module_& m) {
  py::class_<PatternGpu>(m, "CudaPattern",
                         "The pattern parametrization p(theta) and its adjoint on the GPU (dense per-panel blocks).")
      .def(py::init([](const Parametrization& p, size_t max_bytes) { return new PatternGpu(p, max_bytes); }),
           py::arg("parametrization"), py::arg("max_bytes"),
           "A GPU copy of `parametrization`'s harmonic blocks, in at most max_bytes of device memory.")
      .def("pattern", &pattern_gpu_pattern, py::arg("parametrization"), py::arg("theta"),
           "p(theta): (n_boundary, 2) -> (n_vertices, 2), as Parametrization.pattern")
      .def("adjoint", &pattern_gpu_adjoint, py::arg("parametrization"), py::arg("g"),
           "(dp/dtheta)^T g: (n_vertices, 2) -> (n_boundary, 2), as Parametrization.adjoint")
      .def("pattern_device", &pattern_gpu_pattern_device, py::arg("parametrization"), py::arg("theta"),
           py::arg("out"), "out = p(theta), DeviceArrays")
      .def("adjoint_device", &pattern_gpu_adjoint_device, py::arg("parametrization"), py::arg("g"), py::arg("out"),
           "out = (dp/dtheta)^T g, DeviceArrays")
      .def_property_readonly("device_bytes", &PatternGpu::device_bytes, "device memory held (bytes)");
}

auto cost_set_gpu_evaluate(CostSetGpu& g, PyCostSet& c, DArr x, DArr p) {
  const int n = c.cs->n_vertices();
  if (x.ndim() != 2 || x.shape(0) != n || x.shape(1) != 3)
    throw py::value_error("x must have shape (" + std::to_string(n) + ", 3)");
  if (p.ndim() != 2 || p.shape(0) != n || p.shape(1) != 2)
    throw py::value_error("p must have shape (" + std::to_string(n) + ", 2)");
  py::array_t<double> gx({py::ssize_t(n), py::ssize_t(3)}), gp({py::ssize_t(n), py::ssize_t(2)});
  double* gxp = gx.mutable_data();
  double* gpp = gp.mutable_data();
  std::array<double, seamfit::opt::kNumCostTerms> t{};
  double v;
  try {
    py::gil_scoped_release nogil;
    v = g.evaluate(x.data(), p.data(), gxp, gpp, &t);
  } catch (const std::logic_error& e) {
    throw py::value_error(e.what());
  }
  return py::make_tuple(v, cost_terms_dict(t), gx, gp);
}

auto cost_set_gpu_evaluate_device(CostSetGpu& g, PyCostSet& c, const DeviceArray& x, const DeviceArray& p,
                                  DeviceArray& gx, DeviceArray& gp) {
  const int n = c.cs->n_vertices();
  require_shape(x, n, 3, "x");
  require_shape(p, n, 2, "p");
  require_shape(gx, n, 3, "grad_x");
  require_shape(gp, n, 2, "grad_p");
  std::array<double, seamfit::opt::kNumCostTerms> t{};
  double v;
  try {
    py::gil_scoped_release nogil;
    v = g.evaluate_device(x.data(), p.data(), gx.data(), gp.data(), &t);
  } catch (const std::logic_error& e) {
    throw py::value_error(e.what());
  }
  return py::make_tuple(v, cost_terms_dict(t));
}

// Binds CudaCostSet, the fitting costs on the GPU.
void bind_cost_set_gpu(py::module_& m) {
  py::class_<CostSetGpu>(m, "CudaCostSet",
                         "The fitting costs (Eq. 11-16) and their gradients on the GPU, mirroring a CostSet.")
      .def(py::init([](PyCostSet& c) { return new CostSetGpu(*c.cs); }), py::arg("cost_set"),
           py::keep_alive<1, 2>(),  // the CPU cost set (strengths, counters) must outlive it
           "A GPU copy of `cost_set`, which it keeps alive.")
      .def("evaluate", &cost_set_gpu_evaluate, py::arg("cost_set"), py::arg("x"), py::arg("p"),
           "-> (value, terms, grad_x, grad_p), as CostSet.evaluate")
      .def("evaluate_device", &cost_set_gpu_evaluate_device, py::arg("cost_set"), py::arg("x"), py::arg("p"),
           py::arg("grad_x"), py::arg("grad_p"),
           "-> (value, terms); the gradients into grad_x and grad_p (DeviceArrays)");
}

}  // namespace

// Binds the GPU pattern and costs: CudaPattern, then CudaCostSet.
void bind_cuda_opt(py::module_& m) {
  bind_pattern_gpu(m);
  bind_cost_set_gpu(m);
}

}  // namespace seamfit::bindings
#endif
