// Python bindings of the CPU simulator's linear solvers: the sparse LDL^T of the
// tangent stiffness (TangentSolver) and the preconditioned MINRES the GPU adjoint
// also runs (minres_solve), for checks against the GPU.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "bindings.hpp"
#include "sim/minres_cpu.hpp"
#include "sim/simulator.hpp"
#include "sim/tangent_solver.hpp"
#include "sim_args.hpp"

namespace py = pybind11;
using seamfit::sim::TangentSolver;

namespace seamfit::bindings {

namespace {

using namespace sim_args;

auto tangent_factorize(TangentSolver& t, DArr x, bool psd, double shift) {
  require_shape(x, t.simulator().n_vertices(), 3, "x");
  require_outside(t.simulator(), x.data());
  py::gil_scoped_release nogil;
  return t.factorize(x.data(), psd, shift);
}

auto tangent_solve(const TangentSolver& t, DArr g) {
  if (!t.ready()) throw SimError("TangentSolver.solve called without a successful factorize");
  py::array_t<double> out(g.size());
  {
    py::gil_scoped_release nogil;
    t.solve(g.data(), out.mutable_data());
  }
  return out;
}

// Binds TangentSolver, the sparse LDL^T of a simulator's tangent stiffness.
void bind_tangent_solver(py::module_& m) {
  py::class_<TangentSolver>(m, "TangentSolver",
                            "Sparse LDL^T solves with a simulator's tangent stiffness (the adjoint's H).")
      .def(py::init<Simulator&>(), py::arg("simulator"), py::keep_alive<1, 2>(),
           "A solver for `simulator`, which it keeps alive.")
      .def("factorize", &tangent_factorize, py::arg("x"), py::arg("psd") = false, py::arg("shift") = 0.0,
           "Factorize H(x) + shift * mean|diag H| * I; False when a pivot vanishes")
      .def("solve", &tangent_solve, py::arg("g"), "(H + shift I)^-1 g with the last successful factorization")
      .def_property_readonly("factorizations", &TangentSolver::factorizations, "factorizations so far");
}

auto minres_solve_arrays(IArr indptr, IArr indices, DArr data, DArr minv, DArr g, DArr lam0, double tolerance,
                         int max_iterations) {
  const py::ssize_t n3 = g.size(), n = n3 / 3;
  require_shape(indptr, n3 + 1, 0, "indptr");
  require_shape(minv, n, 6, "minv");
  require_shape(lam0, n3, 0, "lam0");
  const int nnz = indptr.data()[n3];
  if (indices.size() != nnz || data.size() != nnz) throw SimError("indices and data must hold indptr[-1] entries");
  for (int k = 0; k < nnz; ++k)
    if (indices.data()[k] < 0 || indices.data()[k] >= n3) throw SimError("a column index is out of range");
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> A(n3, n3, nnz, indptr.data(), indices.data(),
                                                                        data.data());
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
}

}  // namespace

// Binds the CPU linear solvers: TangentSolver and minres_solve.
void bind_sim_solvers(py::module_& m) {
  bind_tangent_solver(m);
  m.def("minres_solve", &minres_solve_arrays, py::arg("indptr"), py::arg("indices"), py::arg("data"), py::arg("minv"),
        py::arg("g"), py::arg("lam0"), py::arg("tolerance") = 1e-8, py::arg("max_iterations") = 10000,
        "Preconditioned MINRES on the CPU with the GPU adjoint's recurrence: A (CSR, 3n x 3n) lam = g from "
        "lam0, with inverse preconditioner blocks minv (n, 6: xx yy zz xy xz yz). Returns (lam, report).");
}

}  // namespace seamfit::bindings
