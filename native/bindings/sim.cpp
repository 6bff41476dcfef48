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
#include "sim/minres_cpu.hpp"
#include "sim/simulator.hpp"
#include "sim/tangent_solver.hpp"
#include "sim_report.hpp"

namespace py = pybind11;
using seamfit::sim::EnergyTerms;
using seamfit::sim::SimError;
using seamfit::sim::SimParams;
using seamfit::sim::Simulator;
using seamfit::sim::SolveReport;
using seamfit::sim::SolveSettings;
using seamfit::sim::TangentSolver;

namespace seamfit::bindings {

namespace {

using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IArr = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;
using FArr = py::array_t<float, py::array::c_style | py::array::forcecast>;

void require_shape(const py::array& a, py::ssize_t rows, py::ssize_t cols, const char* what) {
  const bool ok = cols > 0 ? (a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols)
                           : (a.ndim() == 1 && a.shape(0) == rows);
  if (!ok) {
    std::string want = cols > 0 ? "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")"
                                : "(" + std::to_string(rows) + ",)";
    throw SimError(std::string(what) + " must have shape " + want);
  }
}

void require_outside(Simulator& s, const double* x) {
  double phi = 0;
  const int v = s.first_inside(x, &phi);
  if (v >= 0)
    throw SimError("vertex " + std::to_string(v) + " is inside the body (phi = " + std::to_string(phi * 1000.0) +
                   " mm): the barrier is undefined there; call project_outside first");
}

template <class T>
py::array_t<T> vec_to_array(const std::vector<T>& v, py::ssize_t cols) {
  if (cols > 1) {
    py::array_t<T> a({py::ssize_t(v.size()) / cols, cols});
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
  }
  py::array_t<T> a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

}  // namespace

void bind_sim(py::module_& m) {
  // Map SimError (and only it) to seamfit.errors.SolveError.
  py::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SimError& e) {
      py::object cls = py::module_::import("seamfit.errors").attr("SolveError");
      PyErr_SetString(cls.ptr(), e.what());
    }
  });

  py::class_<SimParams>(m, "SimParams", "Model constants of the simulator, SI units.")
      .def(py::init<>())
      .def_readwrite("stretch_Y", &SimParams::stretch_Y, "Y^patch (N): E = Y/(2L)(l - rL)^2")
      .def_readwrite("sewing_Y", &SimParams::sewing_Y, "Y^sewing (N/m): E = Ys/2 |xi - xj|^2")
      .def_readwrite("bend_kb", &SimParams::bend_kb, "flexural rigidity (N m)")
      .def_readwrite("density", &SimParams::density, "areal density (kg/m^2)")
      .def_property(
          "gravity", [](const SimParams& p) { return std::vector<double>{p.gravity.x, p.gravity.y, p.gravity.z}; },
          [](SimParams& p, const std::vector<double>& g) {
            if (g.size() != 3) throw SimError("gravity must have 3 components");
            p.gravity = {g[0], g[1], g[2]};
          })
      .def_readwrite("mu", &SimParams::mu, "dimensionless barrier strength")
      .def_readwrite("barrier_length", &SimParams::barrier_length, "barrier length scale l_b (m)")
      .def_readwrite("barrier_distance", &SimParams::barrier_distance, "barrier activation distance d (m)")
      .def_readwrite("barrier_smooth", &SimParams::barrier_smooth,
                     "barrier field: cubic B-spline of the grid (True) or trilinear (False)");

  py::class_<SolveSettings>(m, "SolveSettings", "Solver controls.")
      .def(py::init<>())
      .def_readwrite("method", &SolveSettings::method, "0: Chebyshev gradient descent, 1: Newton")
      .def_readwrite("max_iterations", &SolveSettings::max_iterations)
      .def_readwrite("tolerance", &SolveSettings::tolerance, "relative residual |f| / |m g|")
      .def_readwrite("max_seconds", &SolveSettings::max_seconds)
      .def_readwrite("rho", &SolveSettings::rho, "Chebyshev spectral radius (<= 0: automatic)")
      .def_readwrite("alpha", &SolveSettings::alpha)
      .def_readwrite("warmup", &SolveSettings::warmup)
      .def_readwrite("rho_max", &SolveSettings::rho_max)
      .def_readwrite("check_every", &SolveSettings::check_every)
      .def_readwrite("progress_every", &SolveSettings::progress_every)
      .def_readwrite("history_every", &SolveSettings::history_every)
      .def_readwrite("newton_exact_first", &SolveSettings::newton_exact_first)
      .def_readwrite("newton_smoothing", &SolveSettings::newton_smoothing,
                     "Newton: block-Jacobi sweeps after each Newton step (0: pure Newton)")
      .def_readwrite("precond_refresh", &SolveSettings::precond_refresh,
                     "Chebyshev (CPU and GPU): iterations between refreshes of the springs' Jacobi blocks")
      .def_readwrite("far_bound", &SolveSettings::far_bound,
                     "Chebyshev (CPU and GPU): bound, not sample, steps beyond the barrier's reach");

  py::class_<Simulator>(m, "Simulator", "Quasistatic garment simulator (Wang 2018, section 4) on the CPU.")
      .def(py::init([](DArr p, IArr tris, IArr sew, const SimParams& params) {
             if (p.ndim() != 2 || p.shape(1) != 2) throw SimError("p must have shape (n, 2)");
             if (tris.ndim() != 2 || tris.shape(1) != 3) throw SimError("triangles must have shape (T, 3)");
             const bool nosew = sew.size() == 0;
             if (!nosew && (sew.ndim() != 2 || sew.shape(1) != 2)) throw SimError("sewing pairs must have shape (K, 2)");
             return new Simulator(int(p.shape(0)), p.data(), int(tris.shape(0)), tris.data(),
                                  nosew ? 0 : int(sew.shape(0)), nosew ? nullptr : sew.data(), params);
           }),
           py::arg("p"), py::arg("triangles"), py::arg("sewing"), py::arg("params"))
      .def_property_readonly("n_vertices", &Simulator::n_vertices)
      .def_property_readonly("n_triangles", &Simulator::n_triangles)
      .def_property_readonly("n_springs", &Simulator::n_springs)
      .def_property_readonly("n_sewing", &Simulator::n_sewing)
      .def_property_readonly("n_hinges", &Simulator::n_hinges)
      .def_property_readonly("springs", [](const Simulator& s) { return vec_to_array(s.springs(), 2); })
      .def_property_readonly("sewing", [](const Simulator& s) { return vec_to_array(s.sewing(), 2); })
      .def_property_readonly("hinges", [](const Simulator& s) { return vec_to_array(s.hinges(), 4); })
      .def_property_readonly("masses", [](const Simulator& s) { return vec_to_array(s.masses(), 1); })
      .def_property_readonly("rest_lengths", [](const Simulator& s) { return vec_to_array(s.rest_lengths(), 1); })
      .def_property_readonly("weight_norm", &Simulator::weight_norm)
      .def_property_readonly("has_sdf", &Simulator::has_sdf)
      .def_property_readonly("projection_gap", &Simulator::projection_gap)
      .def_property("params", &Simulator::params, &Simulator::set_params)
      .def_property("threads", &Simulator::threads, &Simulator::set_threads,
                    "OpenMP threads (set 0 for automatic: 1 below 3000 vertices)")
      .def("set_sdf",
           [](Simulator& s, py::array_t<float, py::array::c_style> values, DArr origin, double spacing) {
             if (values.ndim() != 3) throw SimError("SDF values must be a 3D array shaped (nz, ny, nx)");
             require_shape(origin, 3, 0, "SDF origin");
             // No copy: the array is kept alive by the simulator (keep_alive below).
             s.set_sdf_view(values.data(), int(values.shape(2)), int(values.shape(1)), int(values.shape(0)),
                            origin.data(), spacing);
           },
           py::arg("values"), py::arg("origin"), py::arg("spacing"), py::keep_alive<1, 2>(),
           "Use a C-contiguous float32 (nz, ny, nx) grid in place (not copied; do not modify it)")
      .def("clear_sdf", &Simulator::clear_sdf)
      .def("set_pattern",
           [](Simulator& s, DArr p) {
             require_shape(p, s.n_vertices(), 2, "p");
             s.set_pattern(p.data());
           })
      .def("set_shirring",
           [](Simulator& s, DArr r) {
             require_shape(r, s.n_springs(), 0, "shirring");
             s.set_shirring(r.data());
           })
      .def("set_sticking",
           [](Simulator& s, DArr k, DArr targets) {
             require_shape(k, s.n_vertices(), 0, "sticking stiffness");
             require_shape(targets, s.n_vertices(), 3, "sticking targets");
             s.set_sticking(k.data(), targets.data());
           },
           py::arg("k"), py::arg("targets"))
      .def("energy",
           [](Simulator& s, DArr x) {
             require_shape(x, s.n_vertices(), 3, "x");
             EnergyTerms t;
             double e;
             {
               py::gil_scoped_release nogil;
               e = s.energy(x.data(), &t);
             }
             return py::make_tuple(e, terms_dict(t));
           })
      .def("force",
           [](Simulator& s, DArr x) {
             require_shape(x, s.n_vertices(), 3, "x");
             require_outside(s, x.data());
             py::array_t<double> f({py::ssize_t(s.n_vertices()), py::ssize_t(3)});
             double* fp = f.mutable_data();
             {
               py::gil_scoped_release nogil;
               s.force(x.data(), fp);
             }
             return f;
           })
      .def("residual",
           [](Simulator& s, DArr x) {
             require_shape(x, s.n_vertices(), 3, "x");
             require_outside(s, x.data());
             std::vector<double> f(3 * size_t(s.n_vertices()));
             py::gil_scoped_release nogil;
             s.force(x.data(), f.data());
             return s.residual(f.data());
           })
      .def("hessian",
           [](Simulator& s, DArr x, bool psd) {
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
           },
           py::arg("x"), py::arg("psd") = false, "CSC components (data, indices, indptr, shape) of the Hessian")
      .def("hess_vec",
           [](Simulator& s, DArr x, DArr v, bool psd) {
             require_shape(x, s.n_vertices(), 3, "x");
             require_shape(v, s.n_vertices(), 3, "v");
             require_outside(s, x.data());
             py::array_t<double> out({py::ssize_t(s.n_vertices()), py::ssize_t(3)});
             double* op = out.mutable_data();
             {
               py::gil_scoped_release nogil;
               s.hess_vec(x.data(), v.data(), op, psd);
             }
             return out;
           },
           py::arg("x"), py::arg("v"), py::arg("psd") = false)
      .def("dfdp_T",
           [](Simulator& s, DArr x, DArr lam) {
             require_shape(x, s.n_vertices(), 3, "x");
             require_shape(lam, s.n_vertices(), 3, "lambda");
             require_outside(s, x.data());
             py::array_t<double> out({py::ssize_t(s.n_vertices()), py::ssize_t(2)});
             double* op = out.mutable_data();
             {
               py::gil_scoped_release nogil;
               s.dfdp_T(x.data(), lam.data(), op);
             }
             return out;
           },
           py::arg("x"), py::arg("lam"), "(df/dp)^T lambda, shape (n, 2), f = -dE/dx")
      .def("sample_phi",
           [](Simulator& s, DArr x, bool barrier_field) {
             require_shape(x, s.n_vertices(), 3, "x");
             py::array_t<double> phi(s.n_vertices());
             double* pp = phi.mutable_data();
             py::gil_scoped_release nogil;
             s.sample_phi(x.data(), pp, barrier_field);
             return phi;
           },
           py::arg("x"), py::arg("barrier_field") = false,
           "phi at every vertex: the grid's trilinear field, or the barrier's field")
      .def("sewing_gaps",
           [](Simulator& s, DArr x) {
             require_shape(x, s.n_vertices(), 3, "x");
             py::array_t<double> g(s.n_sewing());
             s.sewing_gaps(x.data(), g.mutable_data());
             return g;
           })
      .def("project_outside",
           [](Simulator& s, DArr x, double floor, double target) {
             require_shape(x, s.n_vertices(), 3, "x");
             py::array_t<double> out({py::ssize_t(s.n_vertices()), py::ssize_t(3)});
             std::copy(x.data(), x.data() + 3 * s.n_vertices(), out.mutable_data());
             const int c = s.project_outside(out.mutable_data(), floor, target);
             return py::make_tuple(out, c);
           },
           py::arg("x"), py::arg("floor"), py::arg("target"))
      .def("solve",
           [](Simulator& s, DArr x0, const SolveSettings& st, py::object progress, py::object step) {
             require_shape(x0, s.n_vertices(), 3, "x");
             const int n = s.n_vertices();
             py::array_t<double> x({py::ssize_t(n), py::ssize_t(3)});
             std::copy(x0.data(), x0.data() + 3 * n, x.mutable_data());
             double* xp = x.mutable_data();
             seamfit::sim::NewtonStepFn step_fn;
             if (!step.is_none()) {
               // step(x, psd, shift, f, forcing) -> (dx, iterations), or None when it
               // failed; called with the GIL retaken. A raising step fails the
               // solve (its message names the failure), it does not escape it.
               step_fn = [&, n](const double* xs, bool psd, double shift, const double* f, double forcing,
                                double* dx) -> int {
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
             const SolveReport rep = with_progress(progress, [&](const seamfit::sim::ProgressFn& fn,
                                                                 const std::atomic<bool>* cancel) {
               return s.solve(xp, st, fn, cancel, step_fn);
             });
             return py::make_tuple(x, report_dict(rep));
           },
           py::arg("x"), py::arg("settings"), py::arg("progress") = py::none(), py::arg("step") = py::none(),
           "Solve from x; returns (x, report). step (Newton only): an outside solver of each Newton "
           "system, step(x, psd, shift, f, forcing) -> (dx, iterations) or None, in place of the sparse LDL^T.");

  py::class_<TangentSolver>(m, "TangentSolver",
                            "Sparse LDL^T solves with a simulator's tangent stiffness (the adjoint's H).")
      .def(py::init<Simulator&>(), py::arg("simulator"), py::keep_alive<1, 2>())
      .def("factorize",
           [](TangentSolver& t, DArr x, bool psd, double shift) {
             require_shape(x, t.simulator().n_vertices(), 3, "x");
             require_outside(t.simulator(), x.data());
             py::gil_scoped_release nogil;
             return t.factorize(x.data(), psd, shift);
           },
           py::arg("x"), py::arg("psd") = false, py::arg("shift") = 0.0,
           "Factorize H(x) + shift * mean|diag H| * I; False when a pivot vanishes")
      .def("solve",
           [](const TangentSolver& t, DArr g) {
             if (!t.ready()) throw SimError("TangentSolver.solve called without a successful factorize");
             py::array_t<double> out(g.size());
             {
               py::gil_scoped_release nogil;
               t.solve(g.data(), out.mutable_data());
             }
             return out;
           },
           py::arg("g"))
      .def_property_readonly("factorizations", &TangentSolver::factorizations);

  m.def(
      "minres_solve",
      [](IArr indptr, IArr indices, DArr data, DArr minv, DArr g, DArr lam0, double tolerance, int max_iterations) {
        const py::ssize_t n3 = g.size(), n = n3 / 3;
        require_shape(indptr, n3 + 1, 0, "indptr");
        require_shape(minv, n, 6, "minv");
        require_shape(lam0, n3, 0, "lam0");
        const int nnz = indptr.data()[n3];
        if (indices.size() != nnz || data.size() != nnz) throw SimError("indices and data must hold indptr[-1] entries");
        for (int k = 0; k < nnz; ++k)
          if (indices.data()[k] < 0 || indices.data()[k] >= n3) throw SimError("a column index is out of range");
        const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> A(
            n3, n3, nnz, indptr.data(), indices.data(), data.data());
        const Eigen::SparseMatrix<double, Eigen::RowMajor> Ac = A;
        std::vector<seamfit::sim::Sym3> blocks(n);
        const double* mp = minv.data();
        for (py::ssize_t i = 0; i < n; ++i)
          blocks[i] = {mp[6 * i], mp[6 * i + 1], mp[6 * i + 2], mp[6 * i + 3], mp[6 * i + 4], mp[6 * i + 5]};
        py::array_t<double> lam(n3);
        std::copy(lam0.data(), lam0.data() + n3, lam.mutable_data());
        seamfit::sim::MinresState st;
        {
          py::gil_scoped_release nogil;
          st = seamfit::sim::minres_solve(Ac, blocks, g.data(), lam.mutable_data(), tolerance, max_iterations);
        }
        py::dict d;
        d["iterations"] = st.it;
        d["status"] = seamfit::sim::minres_status_name(st.status);
        d["estimate"] = st.bnorm > 0 ? st.phibar / st.bnorm : 0.0;
        d["residual"] = st.gnorm2 > 0 ? std::sqrt(st.rnorm2 / st.gnorm2) : std::sqrt(st.rnorm2);
        return py::make_tuple(lam, d);
      },
      py::arg("indptr"), py::arg("indices"), py::arg("data"), py::arg("minv"), py::arg("g"), py::arg("lam0"),
      py::arg("tolerance") = 1e-8, py::arg("max_iterations") = 10000,
      "Preconditioned MINRES on the CPU with the GPU adjoint's recurrence: A (CSR, 3n x 3n) lam = g from "
      "lam0, with inverse preconditioner blocks minv (n, 6: xx yy zz xy xz yz). Returns (lam, report).");
}

}  // namespace seamfit::bindings
