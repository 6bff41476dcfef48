// Python bindings of the CUDA simulator backend (seamfit._core.CudaSimulator).
// Present only in builds with the CUDA backend; seamfit.sim.cuda says why it
// cannot run otherwise.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "py_cost_set.hpp"

#ifdef SEAMFIT_WITH_CUDA
#include <atomic>
#include <string>

#include "sim/simulator.hpp"
#include "adjoint_gpu.hpp"
#include "costs_gpu.hpp"
#include "dfdp_gpu.hpp"
#include "newton_gpu.hpp"
#include "pattern_gpu.hpp"
#include "py_device_array.hpp"
#include "sim_gpu.hpp"
#include "sim_report.hpp"
#endif

namespace py = pybind11;

namespace seamfit::bindings {

#ifdef SEAMFIT_WITH_CUDA
namespace {

using seamfit::cuda::CudaError;
using seamfit::cuda::GpuOptions;
using seamfit::cuda::SimGpu;
using seamfit::sim::EnergyTerms;
using seamfit::sim::SimError;
using seamfit::sim::Simulator;
using seamfit::sim::SolveReport;
using seamfit::sim::SolveSettings;
using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;

void require_x(const SimGpu& g, const py::array& x) {
  const int n = g.simulator().n_vertices();
  if (x.ndim() != 2 || x.shape(0) != n || x.shape(1) != 3)
    throw SimError("x must have shape (" + std::to_string(n) + ", 3)");
}

void require_outside(SimGpu& g, const double* x) {
  double phi = 0;
  const int v = g.first_inside(x, &phi);
  if (v >= 0)
    throw SimError("vertex " + std::to_string(v) + " is inside the body (phi = " + std::to_string(phi * 1000.0) +
                   " mm): the barrier is undefined there; call project_outside first");
}

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

using seamfit::cuda::DeviceArray;

void require_x(const SimGpu& g, const DeviceArray& x, const char* name = "x") {
  require_shape(x, g.simulator().n_vertices(), 3, name);
}

// As require_outside, for a state in device memory (the check runs there).
void require_outside_device(SimGpu& g, const DeviceArray& x) {
  const int v = g.first_unsafe_device(x.data(), 0.0);
  if (v >= 0)
    throw SimError("vertex " + std::to_string(v) + " is inside the body or not finite: the barrier is undefined "
                   "there; call project_outside first");
}

py::dict adjoint_report_dict(const seamfit::cuda::AdjointReport& r) {
  py::dict d;
  d["converged"] = r.converged;
  d["status"] = r.status;
  d["iterations"] = r.iterations;
  d["residual"] = r.residual;
  d["estimate"] = r.estimate;
  d["shift"] = r.shift;
  d["seconds"] = r.seconds;
  d["message"] = r.message;
  return d;
}

seamfit::cuda::AdjointSettings adjoint_settings(double tolerance, int max_iterations, int batch, bool persistent) {
  seamfit::cuda::AdjointSettings st;
  st.tolerance = tolerance;
  st.max_iterations = max_iterations;
  st.batch = batch;
  st.persistent = persistent;
  return st;
}

// The keys of Simulator.solve's report (sim_report.hpp), plus the device.
py::dict report_dict(const SolveReport& r, const SimGpu& g) {
  py::dict d = seamfit::bindings::report_dict(r);
  d["device"] = g.device_name();
  return d;
}

// A solve from a copy of x0: (x, report dict), run(x, progress, cancel) with the
// GIL released and progress relayed to Python.
template <class Run>
py::tuple solve_from(SimGpu& g, const DArr& x0, const py::object& progress, Run&& run) {
  require_x(g, x0);
  const int n = g.simulator().n_vertices();
  py::array_t<double> x({py::ssize_t(n), py::ssize_t(3)});
  std::copy(x0.data(), x0.data() + 3 * size_t(n), x.mutable_data());
  double* xp = x.mutable_data();
  const SolveReport rep = with_progress(progress, [&](const seamfit::sim::ProgressFn& fn,
                                                      const std::atomic<bool>* cancel) { return run(xp, fn, cancel); });
  return py::make_tuple(x, report_dict(rep, g));
}

}  // namespace
#endif

void bind_cuda_sim(py::module_& m) {
#ifdef SEAMFIT_WITH_CUDA
  py::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const CudaError& e) {
      py::object cls = py::module_::import("seamfit.errors").attr("DeviceError");
      PyErr_SetString(cls.ptr(), e.what());
    }
  });

  py::class_<SimGpu>(m, "CudaSimulator",
                     "GPU mirror of a Simulator: force, energy and the Chebyshev solve on a CUDA device.")
      .def(py::init([](const Simulator& s, int device, int block, int lanes, int batch, bool use_graph,
                       bool float_rest) {
             GpuOptions o;
             o.device = device;
             o.block = block;
             o.lanes = lanes;
             o.batch = batch;
             o.use_graph = use_graph;
             o.float_rest = float_rest;
             return new SimGpu(s, o);
           }),
           py::arg("simulator"), py::arg("device") = 0, py::arg("block") = 128, py::arg("lanes") = 0,
           py::arg("batch") = 32,
           py::arg("use_graph") = true, py::arg("float_rest") = false,
           py::keep_alive<1, 2>())  // the CPU simulator must outlive its GPU copy
      .def("sync", &SimGpu::sync,
           "Bring the device up to the CPU simulator's model: what changed moves; a new pattern's rest state "
           "is computed on the device.")
      .def_property_readonly("weight_norm", &SimGpu::weight_norm,
                             "|m g0| of the synced rest state (the residual scale), computed on the device")
      .def("rest_state",
           [](SimGpu& g) {
             // For tests: the device's float64 rest state, copied back.
             g.sync();
             const seamfit::cuda::DeviceRest d = g.device_rest();
             auto fetch = [](const double* src, size_t count) {
               py::array_t<double> a{py::ssize_t(count)};
               if (count) seamfit::cuda::copy_to_host(a.mutable_data(), src, count * sizeof(double));
               return a;
             };
             py::dict r;
             r["rest_lengths"] = fetch(d.rest_L, size_t(d.n_springs));
             r["masses"] = fetch(d.mass, size_t(d.n));
             r["weight_norm"] = g.weight_norm();
             return r;
           },
           "The device's rest lengths, masses and weight norm (after a sync), for comparison with the CPU's.")
      .def("pattern",
           [](SimGpu& g) {
             // No sync: the pattern the device holds now, which may be one set there alone.
             const seamfit::cuda::DeviceRest d = g.device_rest();
             py::array_t<double> p({py::ssize_t(d.n), py::ssize_t(2)});
             seamfit::cuda::copy_to_host(p.mutable_data(), d.p, 2 * size_t(d.n) * sizeof(double));
             return p;
           },
           "The device's pattern (n, 2), copied back.")
      .def_property_readonly("device_name", &SimGpu::device_name)
      .def_property_readonly("device_bytes", &SimGpu::device_bytes)
      .def_property_readonly("float_rest", [](const SimGpu& g) { return g.options().float_rest; })
      .def_property_readonly("batch", [](const SimGpu& g) { return g.options().batch; })
      .def_property_readonly("lanes", &SimGpu::lanes, "threads per vertex in the force evaluation")
      .def("energy",
           [](SimGpu& g, DArr x) {
             require_x(g, x);
             EnergyTerms t;
             double e;
             {
               py::gil_scoped_release nogil;
               e = g.energy(x.data(), &t);
             }
             return py::make_tuple(e, terms_dict(t));
           })
      .def("force",
           [](SimGpu& g, DArr x) {
             require_x(g, x);
             require_outside(g, x.data());
             py::array_t<double> f({py::ssize_t(g.simulator().n_vertices()), py::ssize_t(3)});
             double* fp = f.mutable_data();
             {
               py::gil_scoped_release nogil;
               g.force(x.data(), fp, nullptr);
             }
             return f;
           })
      .def("hess_vec",
           [](SimGpu& g, DArr x, DArr v, bool psd) {
             require_x(g, x);
             require_x(g, v);
             require_outside(g, x.data());
             py::array_t<double> out({py::ssize_t(g.simulator().n_vertices()), py::ssize_t(3)});
             double* op = out.mutable_data();
             {
               py::gil_scoped_release nogil;
               g.hess_vec(x.data(), v.data(), op, psd);
             }
             return out;
           },
           py::arg("x"), py::arg("v"), py::arg("psd") = false)
      .def("solve",
           [](SimGpu& g, DArr x0, const SolveSettings& st, py::object progress) {
             return solve_from(g, x0, progress, [&](double* xp, const seamfit::sim::ProgressFn& fn,
                                                    const std::atomic<bool>* cancel) {
               return g.solve(xp, st, fn, cancel);
             });
           },
           py::arg("x"), py::arg("settings"), py::arg("progress") = py::none())
      .def("solve_device",
           [](SimGpu& g, DeviceArray& x, const SolveSettings& st, py::object progress) {
             require_x(g, x);
             const SolveReport rep = with_progress(progress, [&](const seamfit::sim::ProgressFn& fn,
                                                                 const std::atomic<bool>* cancel) {
               return g.solve_device(x.data(), st, fn, cancel);
             });
             return report_dict(rep, g);
           },
           py::arg("x"), py::arg("settings"), py::arg("progress") = py::none(),
           "The solve with x a DeviceArray (n, 3), updated in place; returns the report.")
      .def("set_pattern_device",
           [](SimGpu& g, const DeviceArray& p) {
             require_shape(p, g.simulator().n_vertices(), 2, "p");
             py::gil_scoped_release nogil;
             g.set_pattern_device(p.data());
           },
           py::arg("p"),
           "A new pattern (DeviceArray (n, 2)) and its rest state on the device alone; the CPU simulator's "
           "next set_pattern replaces it.")
      .def("newton",
           [](SimGpu& g, Simulator& sim, seamfit::cuda::AdjointGpu& lin, DArr x0, const SolveSettings& st,
              py::object progress, int max_linear_iterations) {
             return solve_from(g, x0, progress, [&](double* xp, const seamfit::sim::ProgressFn& fn,
                                                    const std::atomic<bool>* cancel) {
               return seamfit::cuda::newton_on_gpu(sim, g, lin, xp, st, fn, cancel, max_linear_iterations);
             });
           },
           py::arg("simulator"), py::arg("adjoint"), py::arg("x"), py::arg("settings"),
           py::arg("progress") = py::none(), py::arg("max_linear_iterations") = 5000,
           "Newton from x with each step solved by MINRES on the GPU (`adjoint`, a CudaAdjoint of this "
           "GPU simulator); line search and the rest on the CPU `simulator` this mirrors. Returns (x, report).")
      .def("time_kernels",
           [](SimGpu& g, DArr x, int reps) {
             require_x(g, x);
             seamfit::cuda::KernelTimes t;
             {
               py::gil_scoped_release nogil;
               t = g.time_kernels(x.data(), reps);
             }
             py::dict d;
             d["eval_us"] = t.eval_us;
             d["step_us"] = t.step_us;
             d["slot_us"] = t.slot_us;
             d["eval_bytes"] = t.eval_bytes;
             d["step_bytes"] = t.step_bytes;
             return d;
           },
           py::arg("x"), py::arg("reps") = 200,
           "Device microseconds of each kernel of an iteration (median of graph replays) and the unique bytes "
           "each must move.");

  using seamfit::cuda::AdjointGpu;
  py::class_<AdjointGpu>(m, "CudaAdjoint",
                         "The adjoint solve H lam = g on the GPU: preconditioned MINRES over the stored "
                         "Hessian blocks of a garment state.")
      .def(py::init([](SimGpu& g) { return new AdjointGpu(g); }), py::arg("gpu"),
           py::keep_alive<1, 2>())  // the GPU simulator must outlive its adjoint
      .def("set_state",
           [](AdjointGpu& a, SimGpu& g, DArr x, bool psd, double shift) {
             require_x(g, x);
             require_outside(g, x.data());
             py::gil_scoped_release nogil;
             a.set_state(x.data(), psd, shift);
           },
           py::arg("gpu"), py::arg("x"), py::arg("psd") = false, py::arg("shift") = 1e-8,
           "Store H at x (exact or PSD-projected), shifted by shift * mean|diag H|, and its preconditioner.")
      .def("set_state_device",
           [](AdjointGpu& a, SimGpu& g, const DeviceArray& x, bool psd, double shift) {
             require_x(g, x);
             require_outside_device(g, x);
             py::gil_scoped_release nogil;
             a.set_state_device(x.data(), psd, shift);
           },
           py::arg("gpu"), py::arg("x"), py::arg("psd") = false, py::arg("shift") = 1e-8,
           "set_state with x a DeviceArray.")
      .def("solve",
           [](AdjointGpu& a, SimGpu& g, DArr rhs, py::object lam0, double tolerance, int max_iterations,
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
             const seamfit::cuda::AdjointSettings st = adjoint_settings(tolerance, max_iterations, batch, persistent);
             seamfit::cuda::AdjointReport r;
             {
               py::gil_scoped_release nogil;
               r = a.solve(rhs.data(), lp, st);
             }
             return py::make_tuple(lam, adjoint_report_dict(r));
           },
           py::arg("gpu"), py::arg("g"), py::arg("lam0") = py::none(), py::arg("tolerance") = 1e-6,
           py::arg("max_iterations") = 20000, py::arg("batch") = 32, py::arg("persistent") = true,
           "Solve H lam = g from lam0 (zeros if None); returns (lam, report).")
      .def("solve_device",
           [](AdjointGpu& a, SimGpu& g, const DeviceArray& rhs, DeviceArray& lam, double tolerance,
              int max_iterations, int batch, bool persistent) {
             require_x(g, rhs, "g");
             require_x(g, lam, "lam");
             const seamfit::cuda::AdjointSettings st = adjoint_settings(tolerance, max_iterations, batch, persistent);
             seamfit::cuda::AdjointReport r;
             {
               py::gil_scoped_release nogil;
               r = a.solve_device(rhs.data(), lam.data(), st);
             }
             return adjoint_report_dict(r);
           },
           py::arg("gpu"), py::arg("g"), py::arg("lam"), py::arg("tolerance") = 1e-6,
           py::arg("max_iterations") = 20000, py::arg("batch") = 32, py::arg("persistent") = true,
           "Solve H lam = g with DeviceArrays, lam the start on entry and the solution on return; returns the "
           "report.");

  using seamfit::cuda::DfdpGpu;
  py::class_<DfdpGpu>(m, "CudaDfdp",
                      "The matrix-free product (df/dp)^T lam of the adjoint gradient on the GPU.")
      .def(py::init([](SimGpu& g) { return new DfdpGpu(g); }), py::arg("gpu"),
           py::keep_alive<1, 2>())  // the GPU simulator must outlive it
      .def("apply",
           [](DfdpGpu& d, SimGpu& g, DArr x, DArr lam) {
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
           },
           py::arg("gpu"), py::arg("x"), py::arg("lam"),
           "(df/dp)^T lam (n, 2) at x for the simulator's current pattern and parameters.")
      .def("apply_device",
           [](DfdpGpu& d, SimGpu& g, const DeviceArray& x, const DeviceArray& lam, DeviceArray& out) {
             g.sync();  // as apply: a pattern set on the device alone stays
             require_x(g, x);
             require_x(g, lam, "lam");
             require_shape(out, g.simulator().n_vertices(), 2, "out");
             require_outside_device(g, x);
             py::gil_scoped_release nogil;
             d.apply_device(x.data(), lam.data(), out.data());
           },
           py::arg("gpu"), py::arg("x"), py::arg("lam"), py::arg("out"),
           "out = (df/dp)^T lam with DeviceArrays.");

  using seamfit::cuda::PatternGpu;
  py::class_<PatternGpu>(m, "CudaPattern",
                         "The pattern parametrization p(theta) and its adjoint on the GPU (dense per-panel blocks).")
      .def(py::init([](const seamfit::opt::Parametrization& p, size_t max_bytes) { return new PatternGpu(p, max_bytes); }),
           py::arg("parametrization"), py::arg("max_bytes"))
      .def("pattern",
           [](PatternGpu& g, const seamfit::opt::Parametrization& p, DArr theta) {
             return pattern_map(theta, p.n_boundary(), p.n_vertices(), "theta",
                                [&](const seamfit::Vec2* in, seamfit::Vec2* out) { g.pattern(in, out); });
           },
           py::arg("parametrization"), py::arg("theta"))
      .def("adjoint",
           [](PatternGpu& g, const seamfit::opt::Parametrization& p, DArr grad) {
             return pattern_map(grad, p.n_vertices(), p.n_boundary(), "g",
                                [&](const seamfit::Vec2* in, seamfit::Vec2* out) { g.adjoint(in, out); });
           },
           py::arg("parametrization"), py::arg("g"))
      .def("pattern_device",
           [](PatternGpu& g, const seamfit::opt::Parametrization& p, const DeviceArray& theta, DeviceArray& out) {
             require_shape(theta, p.n_boundary(), 2, "theta");
             require_shape(out, p.n_vertices(), 2, "p");
             py::gil_scoped_release nogil;
             g.pattern_device(theta.data(), out.data());
           },
           py::arg("parametrization"), py::arg("theta"), py::arg("out"), "out = p(theta), DeviceArrays")
      .def("adjoint_device",
           [](PatternGpu& g, const seamfit::opt::Parametrization& p, const DeviceArray& grad, DeviceArray& out) {
             require_shape(grad, p.n_vertices(), 2, "g");
             require_shape(out, p.n_boundary(), 2, "out");
             py::gil_scoped_release nogil;
             g.adjoint_device(grad.data(), out.data());
           },
           py::arg("parametrization"), py::arg("g"), py::arg("out"), "out = (dp/dtheta)^T g, DeviceArrays")
      .def_property_readonly("device_bytes", &PatternGpu::device_bytes);

  using seamfit::cuda::CostSetGpu;
  py::class_<CostSetGpu>(m, "CudaCostSet",
                         "The fitting costs (Eq. 11-16) and their gradients on the GPU, mirroring a CostSet.")
      .def(py::init([](PyCostSet& c) { return new CostSetGpu(*c.cs); }), py::arg("cost_set"),
           py::keep_alive<1, 2>())  // the CPU cost set (strengths, counters) must outlive it
      .def("evaluate",
           [](CostSetGpu& g, PyCostSet& c, DArr x, DArr p) {
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
           },
           py::arg("cost_set"), py::arg("x"), py::arg("p"), "-> (value, terms, grad_x, grad_p), as CostSet.evaluate")
      .def("evaluate_device",
           [](CostSetGpu& g, PyCostSet& c, const DeviceArray& x, const DeviceArray& p, DeviceArray& gx,
              DeviceArray& gp) {
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
           },
           py::arg("cost_set"), py::arg("x"), py::arg("p"), py::arg("grad_x"), py::arg("grad_p"),
           "-> (value, terms); the gradients into grad_x and grad_p (DeviceArrays)");
#else
  (void)m;
#endif
}

}  // namespace seamfit::bindings
