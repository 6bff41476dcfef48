// Python bindings of the quasistatic simulator (seamfit._core.Simulator).
// Arrays cross as numpy (float64 positions, int32 indices, float32 SDF values);
// long calls release the GIL.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <string>

#include "bindings.hpp"
#include "py_errors.hpp"
#include "py_fill.hpp"
#include "sim/simulator.hpp"
#include "sim_args.hpp"
#include "sim_report.hpp"

namespace py = pybind11;
using seamfit::sim::SimParams;
using seamfit::sim::SolveReport;
using seamfit::sim::SolveSettings;

namespace seamfit::bindings {

namespace {

using namespace sim_args;
using SimClass = py::class_<Simulator>;

constexpr char kSolveError[] = "SolveError";  // SimError's face in seamfit.errors

// Binds SimParams, the model constants.
void bind_sim_params(py::module_& m) {
  py::class_<SimParams>(m, "SimParams", "Model constants of the simulator, SI units.")
      .def(py::init<>(), "Default constants.")
      .def_readwrite("stretch_Y", &SimParams::stretch_Y, "Y^patch (N): E = Y/(2L)(l - rL)^2")
      .def_readwrite("sewing_Y", &SimParams::sewing_Y, "Y^sewing (N/m): E = Ys/2 |xi - xj|^2")
      .def_readwrite("bend_kb", &SimParams::bend_kb, "flexural rigidity (N m)")
      .def_readwrite("density", &SimParams::density, "areal density (kg/m^2)")
      .def_property(
          "gravity", [](const SimParams& p) { return std::vector<double>{p.gravity.x, p.gravity.y, p.gravity.z}; },
          [](SimParams& p, const std::vector<double>& g) {
            if (g.size() != 3) throw SimError("gravity must have 3 components");
            p.gravity = {g[0], g[1], g[2]};
          },
          "gravitational acceleration (m/s^2), 3 components")
      .def_readwrite("mu", &SimParams::mu, "dimensionless barrier strength")
      .def_readwrite("barrier_length", &SimParams::barrier_length, "barrier length scale l_b (m)")
      .def_readwrite("barrier_distance", &SimParams::barrier_distance, "barrier activation distance d (m)")
      .def_readwrite("barrier_smooth", &SimParams::barrier_smooth,
                     "barrier field: cubic B-spline of the grid (True) or trilinear (False)");
}

// Binds SolveSettings, the solver controls.
void bind_solve_settings(py::module_& m) {
  py::class_<SolveSettings>(m, "SolveSettings", "Solver controls.")
      .def(py::init<>(), "Default controls.")
      .def_readwrite("method", &SolveSettings::method, "0: Chebyshev gradient descent, 1: Newton")
      .def_readwrite("max_iterations", &SolveSettings::max_iterations, "iteration limit")
      .def_readwrite("tolerance", &SolveSettings::tolerance, "relative residual |f| / |m g|")
      .def_readwrite("max_seconds", &SolveSettings::max_seconds, "time limit (s; 0: none)")
      .def_readwrite("rho", &SolveSettings::rho, "Chebyshev spectral radius (<= 0: automatic)")
      .def_readwrite("alpha", &SolveSettings::alpha, "Jacobi step length")
      .def_readwrite("warmup", &SolveSettings::warmup, "plain Jacobi iterations after each (re)start")
      .def_readwrite("rho_max", &SolveSettings::rho_max, "upper bound of the adapted Chebyshev rho")
      .def_readwrite("check_every", &SolveSettings::check_every,
                     "Chebyshev: iterations between energy checks and checkpoints")
      .def_readwrite("progress_every", &SolveSettings::progress_every, "iterations between progress callbacks")
      .def_readwrite("history_every", &SolveSettings::history_every, "iterations between residual history entries")
      .def_readwrite("newton_exact_first", &SolveSettings::newton_exact_first,
                     "Newton: try the exact Hessian before the PSD-projected one")
      .def_readwrite("newton_smoothing", &SolveSettings::newton_smoothing,
                     "Newton: block-Jacobi sweeps after each Newton step (0: pure Newton)")
      .def_readwrite("precond_refresh", &SolveSettings::precond_refresh,
                     "Chebyshev (CPU and GPU): iterations between refreshes of the springs' Jacobi blocks")
      .def_readwrite("far_bound", &SolveSettings::far_bound,
                     "Chebyshev (CPU and GPU): bound, not sample, steps beyond the barrier's reach");
}

auto make_simulator(DArr p, IArr tris, IArr sew, const SimParams& params) {
  if (p.ndim() != 2 || p.shape(1) != 2) throw SimError("p must have shape (n, 2)");
  if (tris.ndim() != 2 || tris.shape(1) != 3) throw SimError("triangles must have shape (T, 3)");
  const bool nosew = sew.size() == 0;
  if (!nosew && (sew.ndim() != 2 || sew.shape(1) != 2)) throw SimError("sewing pairs must have shape (K, 2)");
  return new Simulator(int(p.shape(0)), p.data(), int(tris.shape(0)), tris.data(), nosew ? 0 : int(sew.shape(0)),
                       nosew ? nullptr : sew.data(), params);
}

// Binds the Simulator's sizes, topology and rest state.
void bind_simulator_layout(SimClass& c) {
  c.def_property_readonly("n_vertices", &Simulator::n_vertices, "number of vertices n")
      .def_property_readonly("n_triangles", &Simulator::n_triangles, "number of triangles")
      .def_property_readonly("n_springs", &Simulator::n_springs, "number of patch springs (mesh edges)")
      .def_property_readonly("n_sewing", &Simulator::n_sewing, "number of sewing pairs")
      .def_property_readonly("n_hinges", &Simulator::n_hinges, "number of bending hinges")
      .def_property_readonly("springs", [](const Simulator& s) { return vec_to_array(s.springs(), 2); },
                             "spring vertex pairs (n_springs, 2)")
      .def_property_readonly("sewing", [](const Simulator& s) { return vec_to_array(s.sewing(), 2); },
                             "sewing vertex pairs (n_sewing, 2)")
      .def_property_readonly("hinges", [](const Simulator& s) { return vec_to_array(s.hinges(), 4); },
                             "hinge vertices (n_hinges, 4)")
      .def_property_readonly("masses", [](const Simulator& s) { return vec_to_array(s.masses(), 1); },
                             "vertex masses (n,) of the rest state (kg)")
      .def_property_readonly("rest_lengths", [](const Simulator& s) { return vec_to_array(s.rest_lengths(), 1); },
                             "spring rest lengths (n_springs,) of the rest state (m)")
      .def_property_readonly("weight_norm", &Simulator::weight_norm, "|m g0| (N), the residual scale")
      .def_property_readonly("has_sdf", &Simulator::has_sdf, "whether a body's signed distance field is set")
      .def_property_readonly("projection_gap", &Simulator::projection_gap,
                             "barrier rest gap mu * l_b (m), bounded");
}

void sim_set_sdf(Simulator& s, py::array_t<float, py::array::c_style> values, DArr origin, double spacing) {
  if (values.ndim() != 3) throw SimError("SDF values must be a 3D array shaped (nz, ny, nx)");
  require_shape(origin, 3, 0, "SDF origin");
  // No copy: the array is kept alive by the simulator (keep_alive at the binding).
  s.set_sdf_view(values.data(), int(values.shape(2)), int(values.shape(1)), int(values.shape(0)), origin.data(),
                 spacing);
}

// A setter of one array: `what` (Rows() rows of Cols columns, 0: a vector) checked, then Set.
template <void (Simulator::*Set)(const double*), int (Simulator::*Rows)() const, int Cols>
auto array_setter(const char* what) {
  return [what](Simulator& s, DArr a) {
    require_shape(a, (s.*Rows)(), Cols, what);
    (s.*Set)(a.data());
  };
}

// Binds the Simulator's inputs: parameters, body, pattern, shirring, sticking.
void bind_simulator_inputs(SimClass& c) {
  c.def_property("params", &Simulator::params, &Simulator::set_params,
                 "model constants (SimParams); setting them keeps the topology")
      .def_property("threads", &Simulator::threads, &Simulator::set_threads,
                    "OpenMP threads (set 0 for automatic: 1 below 3000 vertices)")
      .def("set_sdf", &sim_set_sdf, py::arg("values"), py::arg("origin"), py::arg("spacing"), py::keep_alive<1, 2>(),
           "Use a C-contiguous float32 (nz, ny, nx) grid in place (not copied; do not modify it)")
      .def("clear_sdf", &Simulator::clear_sdf, "Remove the body: no barrier, phi = +inf.")
      .def("set_pattern", array_setter<&Simulator::set_pattern, &Simulator::n_vertices, 2>("p"),
           "A new pattern (n, 2) (m); its rest state is computed on first use.")
      .def("set_shirring", array_setter<&Simulator::set_shirring, &Simulator::n_springs, 0>("shirring"),
           "Rest length ratio per patch spring (n_springs,).")
      .def(
          "set_sticking",
          [](Simulator& s, DArr k, DArr targets) {
            require_shape(k, s.n_vertices(), 0, "sticking stiffness");
            require_shape(targets, s.n_vertices(), 3, "sticking targets");
            s.set_sticking(k.data(), targets.data());
          },
          py::arg("k"), py::arg("targets"), "Sticking stiffness k (n,) (N/m, 0: free) toward targets (n, 3).");
}

auto sim_energy(Simulator& s, DArr x) {
  require_shape(x, s.n_vertices(), 3, "x");
  return energy_and_terms(s, x.data());
}

auto sim_force(Simulator& s, DArr x) {
  require_shape(x, s.n_vertices(), 3, "x");
  require_outside(s, x.data());
  return fill_released(s.n_vertices(), 3, [&](double* f) { s.force(x.data(), f); });
}

auto sim_residual(Simulator& s, DArr x) {
  require_shape(x, s.n_vertices(), 3, "x");
  require_outside(s, x.data());
  std::vector<double> f(3 * size_t(s.n_vertices()));
  py::gil_scoped_release nogil;
  s.force(x.data(), f.data());
  return s.residual(f.data());
}

auto sim_hessian(Simulator& s, DArr x, bool psd) {
  require_shape(x, s.n_vertices(), 3, "x");
  require_outside(s, x.data());
  const Eigen::SparseMatrix<double>* H;
  {
    py::gil_scoped_release nogil;
    H = &s.hessian(x.data(), psd);
  }
  const py::ssize_t nnz = H->nonZeros(), cols = H->cols();
  py::array_t<double> data(nnz);
  py::array_t<int32_t> indices(nnz), indptr(cols + 1);
  std::copy(H->valuePtr(), H->valuePtr() + nnz, data.mutable_data());
  std::copy(H->innerIndexPtr(), H->innerIndexPtr() + nnz, indices.mutable_data());
  std::copy(H->outerIndexPtr(), H->outerIndexPtr() + cols + 1, indptr.mutable_data());
  return py::make_tuple(data, indices, indptr, py::make_tuple(H->rows(), cols));
}

auto sim_hess_vec(Simulator& s, DArr x, DArr v, bool psd) {
  require_shape(x, s.n_vertices(), 3, "x");
  require_shape(v, s.n_vertices(), 3, "v");
  require_outside(s, x.data());
  return fill_released(s.n_vertices(), 3, [&](double* out) { s.hess_vec(x.data(), v.data(), out, psd); });
}

auto sim_dfdp_T(Simulator& s, DArr x, DArr lam) {
  require_shape(x, s.n_vertices(), 3, "x");
  require_shape(lam, s.n_vertices(), 3, "lambda");
  require_outside(s, x.data());
  return fill_released(s.n_vertices(), 2, [&](double* out) { s.dfdp_T(x.data(), lam.data(), out); });
}

// Binds the Simulator's energy and its derivatives at a state x (n, 3).
void bind_simulator_energy(SimClass& c) {
  c.def("energy", &sim_energy, "-> (energy (J), terms); +inf when a vertex is inside the body")
      .def("force", &sim_force, "f = -dE/dx (n, 3); x must be outside the body")
      .def("residual", &sim_residual, "relative residual |f| / |m g0| at x")
      .def("hessian", &sim_hessian, py::arg("x"), py::arg("psd") = false,
           "CSC components (data, indices, indptr, shape) of the Hessian")
      .def("hess_vec", &sim_hess_vec, py::arg("x"), py::arg("v"), py::arg("psd") = false,
           "(d2E/dx2) v (n, 3), matrix-free; psd: the PSD-projected Hessian")
      .def("dfdp_T", &sim_dfdp_T, py::arg("x"), py::arg("lam"), "(df/dp)^T lambda, shape (n, 2), f = -dE/dx");
}

auto sim_sample_phi(Simulator& s, DArr x, bool barrier_field) {
  require_shape(x, s.n_vertices(), 3, "x");
  py::array_t<double> phi(s.n_vertices());
  double* pp = phi.mutable_data();
  py::gil_scoped_release nogil;
  s.sample_phi(x.data(), pp, barrier_field);
  return phi;
}

auto sim_sewing_gaps(Simulator& s, DArr x) {
  require_shape(x, s.n_vertices(), 3, "x");
  py::array_t<double> g(s.n_sewing());
  s.sewing_gaps(x.data(), g.mutable_data());
  return g;
}

auto sim_project_outside(Simulator& s, DArr x, double floor, double target) {
  require_shape(x, s.n_vertices(), 3, "x");
  py::array_t<double> out({py::ssize_t(s.n_vertices()), py::ssize_t(3)});
  std::copy(x.data(), x.data() + 3 * s.n_vertices(), out.mutable_data());
  const int c = s.project_outside(out.mutable_data(), floor, target);
  return py::make_tuple(out, c);
}

// Binds the Simulator's queries of a state against the body and the seams.
void bind_simulator_geometry(SimClass& c) {
  c.def("sample_phi", &sim_sample_phi, py::arg("x"), py::arg("barrier_field") = false,
        "phi at every vertex: the grid's trilinear field, or the barrier's field")
      .def("sewing_gaps", &sim_sewing_gaps, "|x_i - x_j| per sewing pair (n_sewing,)")
      .def("project_outside", &sim_project_outside, py::arg("x"), py::arg("floor"), py::arg("target"),
           "Move vertices with phi < floor out to phi = target; returns (x, count moved).");
}

// step(x, psd, shift, f, forcing) -> (dx, iterations), or None when it failed;
// called with the GIL retaken. A raising step fails the solve (its message names
// the failure), it does not escape it.
seamfit::sim::NewtonStepFn newton_step_fn(const py::object& step, int n) {
  return [&step, n](const double* xs, bool psd, double shift, const double* f, double forcing, double* dx) -> int {
    py::gil_scoped_acquire gil;
    try {
      py::array_t<double> xa({py::ssize_t(n), py::ssize_t(3)}), fa({py::ssize_t(n), py::ssize_t(3)});
      std::copy(xs, xs + 3 * n, xa.mutable_data());
      std::copy(f, f + 3 * n, fa.mutable_data());
      py::object r = step(xa, psd, shift, fa, forcing);
      if (r.is_none()) return -1;
      auto t = r.cast<py::tuple>();
      DArr d = t[0].cast<DArr>();
      if (d.size() != 3 * py::ssize_t(n)) return -1;
      std::copy(d.data(), d.data() + 3 * n, dx);
      return std::max(0, t[1].cast<int>());
    } catch (py::error_already_set&) {
      return -1;
    }
  };
}

auto sim_solve(Simulator& s, DArr x0, const SolveSettings& st, py::object progress, py::object step) {
  require_shape(x0, s.n_vertices(), 3, "x");
  const int n = s.n_vertices();
  py::array_t<double> x({py::ssize_t(n), py::ssize_t(3)});
  std::copy(x0.data(), x0.data() + 3 * n, x.mutable_data());
  double* xp = x.mutable_data();
  seamfit::sim::NewtonStepFn step_fn;
  if (!step.is_none()) step_fn = newton_step_fn(step, n);  // `step` outlives the solve
  const SolveReport rep =
      with_progress(progress, [&](const seamfit::sim::ProgressFn& fn, const std::atomic<bool>* cancel) {
        return s.solve(xp, st, fn, cancel, step_fn);
      });
  return py::make_tuple(x, report_dict(rep));
}

// Binds Simulator: construction, then its members by group.
void bind_simulator(py::module_& m) {
  SimClass c(m, "Simulator", "Quasistatic garment simulator (Wang 2018, section 4) on the CPU.");
  c.def(py::init(&make_simulator), py::arg("p"), py::arg("triangles"), py::arg("sewing"), py::arg("params"),
        "A garment from its pattern p (n, 2), triangles (T, 3), sewing pairs (K, 2) and SimParams.");
  bind_simulator_layout(c);
  bind_simulator_inputs(c);
  bind_simulator_energy(c);
  bind_simulator_geometry(c);
  c.def("solve", &sim_solve, py::arg("x"), py::arg("settings"), py::arg("progress") = py::none(),
        py::arg("step") = py::none(),
        "Solve from x; returns (x, report). step (Newton only): an outside solver of each Newton "
        "system, step(x, psd, shift, f, forcing) -> (dx, iterations) or None, in place of the sparse LDL^T.");
}

}  // namespace

// Binds the CPU simulator: its error, parameters, settings, the Simulator and its linear solvers.
void bind_sim(py::module_& m) {
  bind_error<SimError, kSolveError>();
  bind_sim_params(m);
  bind_solve_settings(m);
  bind_simulator(m);
  bind_sim_solvers(m);  // after Simulator: TangentSolver's signature names it
}

}  // namespace seamfit::bindings
