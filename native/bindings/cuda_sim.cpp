// Python bindings of the CUDA simulator backend (seamfit._core.CudaSimulator), and
// the entry point of every CUDA binding. Present only in builds with the CUDA
// backend; seamfit.sim.cuda says why it cannot run otherwise.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

#ifdef SEAMFIT_WITH_CUDA
#include <atomic>
#include <string>

#include "cuda_args.hpp"
#include "py_errors.hpp"
#include "py_fill.hpp"
#include "sim/adjoint_gpu.hpp"
#include "sim/newton_gpu.hpp"
#include "sim/sim_gpu.hpp"
#include "sim/simulator.hpp"
#include "sim_report.hpp"
#endif

namespace py = pybind11;

namespace seamfit::bindings {

#ifdef SEAMFIT_WITH_CUDA
namespace {

using namespace cuda_args;
using seamfit::cuda::CudaError;
using seamfit::cuda::GpuOptions;
using GpuClass = py::class_<SimGpu>;

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

constexpr char kDeviceError[] = "DeviceError";  // CudaError's face in seamfit.errors

auto make_sim_gpu(const Simulator& s, int device, int block, int lanes, int batch, bool use_graph,
                  bool float_rest) {
  GpuOptions o;
  o.device = device;
  o.block = block;
  o.lanes = lanes;
  o.batch = batch;
  o.use_graph = use_graph;
  o.float_rest = float_rest;
  return new SimGpu(s, o);
}

// For tests: the device's float64 rest state, copied back.
auto sim_gpu_rest_state(SimGpu& g) {
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
}

auto sim_gpu_pattern(SimGpu& g) {
  // No sync: the pattern the device holds now, which may be one set there alone.
  const seamfit::cuda::DeviceRest d = g.device_rest();
  py::array_t<double> p({py::ssize_t(d.n), py::ssize_t(2)});
  seamfit::cuda::copy_to_host(p.mutable_data(), d.p, 2 * size_t(d.n) * sizeof(double));
  return p;
}

// Binds the CudaSimulator's model on the device: sync, rest state, pattern, sizes.
void bind_sim_gpu_model(GpuClass& c) {
  c.def("sync", &SimGpu::sync,
        "Bring the device up to the CPU simulator's model: what changed moves; a new pattern's rest state "
        "is computed on the device.")
      .def_property_readonly("weight_norm", &SimGpu::weight_norm,
                             "|m g0| of the synced rest state (the residual scale), computed on the device")
      .def("rest_state", &sim_gpu_rest_state,
           "The device's rest lengths, masses and weight norm (after a sync), for comparison with the CPU's.")
      .def("pattern", &sim_gpu_pattern, "The device's pattern (n, 2), copied back.")
      .def_property_readonly("device_name", &SimGpu::device_name, "name of the CUDA device")
      .def_property_readonly("device_bytes", &SimGpu::device_bytes, "device memory held (bytes)")
      .def_property_readonly(
          "float_rest", [](const SimGpu& g) { return g.options().float_rest; },
          "whether the rest state is stored as float32")
      .def_property_readonly(
          "batch", [](const SimGpu& g) { return g.options().batch; },
          "iterations per graph launch between host looks")
      .def_property_readonly("lanes", &SimGpu::lanes, "threads per vertex in the force evaluation");
}

auto sim_gpu_energy(SimGpu& g, DArr x) {
  require_x(g, x);
  return energy_and_terms(g, x.data());
}

auto sim_gpu_force(SimGpu& g, DArr x) {
  require_x(g, x);
  require_outside(g, x.data());
  return fill_released(g.simulator().n_vertices(), 3, [&](double* f) { g.force(x.data(), f, nullptr); });
}

auto sim_gpu_hess_vec(SimGpu& g, DArr x, DArr v, bool psd) {
  require_x(g, x);
  require_x(g, v);
  require_outside(g, x.data());
  return fill_released(g.simulator().n_vertices(), 3,
                       [&](double* out) { g.hess_vec(x.data(), v.data(), out, psd); });
}

// Binds the CudaSimulator's energy, force and Hessian product at a host state.
void bind_sim_gpu_energy(GpuClass& c) {
  c.def("energy", &sim_gpu_energy, "-> (energy (J), terms), as Simulator.energy")
      .def("force", &sim_gpu_force, "f = -dE/dx (n, 3), as Simulator.force")
      .def("hess_vec", &sim_gpu_hess_vec, py::arg("x"), py::arg("v"), py::arg("psd") = false,
           "(d2E/dx2) v (n, 3), as Simulator.hess_vec");
}

auto sim_gpu_solve(SimGpu& g, DArr x0, const SolveSettings& st, py::object progress) {
  return solve_from(g, x0, progress,
                    [&](double* xp, const seamfit::sim::ProgressFn& fn, const std::atomic<bool>* cancel) {
                      return g.solve(xp, st, fn, cancel);
                    });
}

auto sim_gpu_solve_device(SimGpu& g, DeviceArray& x, const SolveSettings& st, py::object progress) {
  require_x(g, x);
  const SolveReport rep =
      with_progress(progress, [&](const seamfit::sim::ProgressFn& fn, const std::atomic<bool>* cancel) {
        return g.solve_device(x.data(), st, fn, cancel);
      });
  return report_dict(rep, g);
}

void sim_gpu_set_pattern_device(SimGpu& g, const DeviceArray& p) {
  require_shape(p, g.simulator().n_vertices(), 2, "p");
  py::gil_scoped_release nogil;
  g.set_pattern_device(p.data());
}

auto sim_gpu_newton(SimGpu& g, Simulator& sim, seamfit::cuda::AdjointGpu& lin, DArr x0, const SolveSettings& st,
                    py::object progress, int max_linear_iterations) {
  return solve_from(g, x0, progress,
                    [&](double* xp, const seamfit::sim::ProgressFn& fn, const std::atomic<bool>* cancel) {
                      return seamfit::cuda::newton_on_gpu(sim, g, lin, xp, st, fn, cancel, max_linear_iterations);
                    });
}

// Binds the CudaSimulator's solves: Chebyshev from host or device state, and Newton.
void bind_sim_gpu_solves(GpuClass& c) {
  c.def("solve", &sim_gpu_solve, py::arg("x"), py::arg("settings"), py::arg("progress") = py::none(),
        "Solve from x on the GPU; returns (x, report), as Simulator.solve.")
      .def("solve_device", &sim_gpu_solve_device, py::arg("x"), py::arg("settings"), py::arg("progress") = py::none(),
           "The solve with x a DeviceArray (n, 3), updated in place; returns the report.")
      .def("set_pattern_device", &sim_gpu_set_pattern_device, py::arg("p"),
           "A new pattern (DeviceArray (n, 2)) and its rest state on the device alone; the CPU simulator's "
           "next set_pattern replaces it.")
      .def("newton", &sim_gpu_newton, py::arg("simulator"), py::arg("adjoint"), py::arg("x"), py::arg("settings"),
           py::arg("progress") = py::none(), py::arg("max_linear_iterations") = 5000,
           "Newton from x with each step solved by MINRES on the GPU (`adjoint`, a CudaAdjoint of this "
           "GPU simulator); line search and the rest on the CPU `simulator` this mirrors. Returns (x, report).");
}

auto sim_gpu_time_kernels(SimGpu& g, DArr x, int reps) {
  require_x(g, x);
  seamfit::cuda::KernelTimes t;
  {
    py::gil_scoped_release nogil;
    t = g.time_kernels(x.data(), reps);
  }
  using namespace py::literals;
  return py::dict("eval_us"_a = t.eval_us, "step_us"_a = t.step_us, "slot_us"_a = t.slot_us,
                  "eval_bytes"_a = t.eval_bytes, "step_bytes"_a = t.step_bytes);
}

// Binds CudaSimulator: construction, then its members by group.
void bind_sim_gpu(py::module_& m) {
  GpuClass c(m, "CudaSimulator",
             "GPU mirror of a Simulator: force, energy and the Chebyshev solve on a CUDA device.");
  c.def(py::init(&make_sim_gpu), py::arg("simulator"), py::arg("device") = 0, py::arg("block") = 128,
        py::arg("lanes") = 0, py::arg("batch") = 32, py::arg("use_graph") = true, py::arg("float_rest") = false,
        py::keep_alive<1, 2>(),  // the CPU simulator must outlive its GPU copy
        "A GPU copy of `simulator` on CUDA device `device`, with the kernels' launch options.");
  bind_sim_gpu_model(c);
  bind_sim_gpu_energy(c);
  bind_sim_gpu_solves(c);
  c.def("time_kernels", &sim_gpu_time_kernels, py::arg("x"), py::arg("reps") = 200,
        "Device microseconds of each kernel of an iteration (median of graph replays) and the unique bytes "
        "each must move.");
}

}  // namespace
#endif

// Binds the CUDA backend: its error, the simulator, then the adjoint and the
// optimizer's GPU blocks (which name CudaSimulator in their signatures).
void bind_cuda_sim(py::module_& m) {
#ifdef SEAMFIT_WITH_CUDA
  bind_error<CudaError, kDeviceError>();
  bind_sim_gpu(m);
  bind_cuda_adjoint(m);
  bind_cuda_opt(m);
#else
  (void)m;
#endif
}

}  // namespace seamfit::bindings
