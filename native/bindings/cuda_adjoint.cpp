// Python bindings of the adjoint on the GPU: the MINRES solve H lam = g
// (CudaAdjoint) and the product (df/dp)^T lam (CudaDfdp). CUDA builds only.
#ifdef SEAMFIT_WITH_CUDA
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>

#include "bindings.hpp"
#include "cuda_args.hpp"
#include "sim/adjoint_gpu.hpp"
#include "sim/dfdp_gpu.hpp"
#include "sim/sim_gpu.hpp"

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using namespace cuda_args;
using seamfit::cuda::AdjointGpu;
using seamfit::cuda::AdjointReport;
using seamfit::cuda::AdjointSettings;
using seamfit::cuda::DfdpGpu;

py::dict adjoint_report_dict(const AdjointReport& r) {
  using namespace py::literals;
  return py::dict("converged"_a = r.converged, "status"_a = r.status, "iterations"_a = r.iterations,
                  "residual"_a = r.residual, "estimate"_a = r.estimate, "shift"_a = r.shift,
                  "seconds"_a = r.seconds, "message"_a = r.message);
}

AdjointSettings adjoint_settings(double tolerance, int max_iterations, int batch, bool persistent) {
  AdjointSettings st;
  st.tolerance = tolerance;
  st.max_iterations = max_iterations;
  st.batch = batch;
  st.persistent = persistent;
  return st;
}

void adjoint_set_state(AdjointGpu& a, SimGpu& g, DArr x, bool psd, double shift) {
  require_x(g, x);
  require_outside(g, x.data());
  py::gil_scoped_release nogil;
  a.set_state(x.data(), psd, shift);
}

void adjoint_set_state_device(AdjointGpu& a, SimGpu& g, const DeviceArray& x, bool psd, double shift) {
  require_x(g, x);
  require_outside_device(g, x);
  py::gil_scoped_release nogil;
  a.set_state_device(x.data(), psd, shift);
}

auto adjoint_solve(AdjointGpu& a, SimGpu& g, DArr rhs, py::object lam0, double tolerance, int max_iterations,
                   int batch, bool persistent) {
  require_x(g, rhs);
  const int n = g.simulator().n_vertices();
  py::array_t<double> lam({py::ssize_t(n), py::ssize_t(3)});
  double* lp = lam.mutable_data();
  if (lam0.is_none()) {
    std::fill(lp, lp + 3 * size_t(n), 0.0);
  } else {
    DArr l0 = lam0.cast<DArr>();
    require_x(g, l0);
    std::copy(l0.data(), l0.data() + 3 * size_t(n), lp);
  }
  const AdjointSettings st = adjoint_settings(tolerance, max_iterations, batch, persistent);
  AdjointReport r;
  {
    py::gil_scoped_release nogil;
    r = a.solve(rhs.data(), lp, st);
  }
  return py::make_tuple(lam, adjoint_report_dict(r));
}

auto adjoint_solve_device(AdjointGpu& a, SimGpu& g, const DeviceArray& rhs, DeviceArray& lam, double tolerance,
                          int max_iterations, int batch, bool persistent) {
  require_x(g, rhs, "g");
  require_x(g, lam, "lam");
  const AdjointSettings st = adjoint_settings(tolerance, max_iterations, batch, persistent);
  AdjointReport r;
  {
    py::gil_scoped_release nogil;
    r = a.solve_device(rhs.data(), lam.data(), st);
  }
  return adjoint_report_dict(r);
}

// Binds CudaAdjoint, the GPU MINRES solve of the adjoint system.
void bind_adjoint_gpu(py::module_& m) {
  py::class_<AdjointGpu>(m, "CudaAdjoint",
                         "The adjoint solve H lam = g on the GPU: preconditioned MINRES over the stored "
                         "Hessian blocks of a garment state.")
      .def(py::init([](SimGpu& g) { return new AdjointGpu(g); }), py::arg("gpu"),
           py::keep_alive<1, 2>(),  // the GPU simulator must outlive its adjoint
           "An adjoint solver on `gpu` (a CudaSimulator), which it keeps alive.")
      .def("set_state", &adjoint_set_state, py::arg("gpu"), py::arg("x"), py::arg("psd") = false,
           py::arg("shift") = 1e-8,
           "Store H at x (exact or PSD-projected), shifted by shift * mean|diag H|, and its preconditioner.")
      .def("set_state_device", &adjoint_set_state_device, py::arg("gpu"), py::arg("x"), py::arg("psd") = false,
           py::arg("shift") = 1e-8, "set_state with x a DeviceArray.")
      .def("solve", &adjoint_solve, py::arg("gpu"), py::arg("g"), py::arg("lam0") = py::none(),
           py::arg("tolerance") = 1e-6, py::arg("max_iterations") = 20000, py::arg("batch") = 32,
           py::arg("persistent") = true, "Solve H lam = g from lam0 (zeros if None); returns (lam, report).")
      .def("solve_device", &adjoint_solve_device, py::arg("gpu"), py::arg("g"), py::arg("lam"),
           py::arg("tolerance") = 1e-6, py::arg("max_iterations") = 20000, py::arg("batch") = 32,
           py::arg("persistent") = true,
           "Solve H lam = g with DeviceArrays, lam the start on entry and the solution on return; returns the "
           "report.");
}

auto dfdp_apply(DfdpGpu& d, SimGpu& g, DArr x, DArr lam) {
  g.sync();  // the pattern as the CPU simulator has it now (nothing moves when unchanged)
  require_x(g, x);
  require_x(g, lam);
  require_outside(g, x.data());
  py::array_t<double> out({py::ssize_t(g.simulator().n_vertices()), py::ssize_t(2)});
  double* op = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    d.apply(x.data(), lam.data(), op);
  }
  return out;
}

void dfdp_apply_device(DfdpGpu& d, SimGpu& g, const DeviceArray& x, const DeviceArray& lam, DeviceArray& out) {
  g.sync();  // as apply: a pattern set on the device alone stays
  require_x(g, x);
  require_x(g, lam, "lam");
  require_shape(out, g.simulator().n_vertices(), 2, "out");
  require_outside_device(g, x);
  py::gil_scoped_release nogil;
  d.apply_device(x.data(), lam.data(), out.data());
}

// Binds CudaDfdp, the adjoint gradient's matrix-free (df/dp)^T lam.
void bind_dfdp_gpu(py::module_& m) {
  py::class_<DfdpGpu>(m, "CudaDfdp", "The matrix-free product (df/dp)^T lam of the adjoint gradient on the GPU.")
      .def(py::init([](SimGpu& g) { return new DfdpGpu(g); }), py::arg("gpu"),
           py::keep_alive<1, 2>(),  // the GPU simulator must outlive it
           "The product for `gpu` (a CudaSimulator), which it keeps alive.")
      .def("apply", &dfdp_apply, py::arg("gpu"), py::arg("x"), py::arg("lam"),
           "(df/dp)^T lam (n, 2) at x for the simulator's current pattern and parameters.")
      .def("apply_device", &dfdp_apply_device, py::arg("gpu"), py::arg("x"), py::arg("lam"), py::arg("out"),
           "out = (df/dp)^T lam with DeviceArrays.");
}

}  // namespace

// Binds the GPU adjoint: CudaAdjoint, then CudaDfdp.
void bind_cuda_adjoint(py::module_& m) {
  bind_adjoint_gpu(m);
  bind_dfdp_gpu(m);
}

}  // namespace seamfit::bindings
#endif
