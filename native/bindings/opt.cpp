// Python bindings of the optimizer's building blocks (native/core/opt). Thin: shape
// checks and array conversion only; seamfit.opt wraps these in the public API.
// This file: the pattern parametrization and the regularizers over theta; the costs
// are in opt_costs.cpp, the GPU copies in opt_cuda.cpp. The core's std::invalid_argument
// reaches Python as ValueError with its message (pybind11's own translation).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <memory>
#include <vector>

#include "bindings.hpp"
#include "opt/parametrization.hpp"
#include "opt/regularizer_set.hpp"
#include "opt/seam_length.hpp"
#include "opt_args.hpp"
#include "py_fill.hpp"

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using namespace opt_args;
using BoolArr = py::array_t<bool, py::array::c_style | py::array::forcecast>;

// A sparse matrix as (rows, cols, values, shape), for scipy.sparse.coo_matrix.
py::tuple triplets(const Eigen::SparseMatrix<double>& m) {
  std::vector<int> r, c;
  std::vector<double> v;
  for (int k = 0; k < m.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(m, k); it; ++it) {
      r.push_back(int(it.row()));
      c.push_back(int(it.col()));
      v.push_back(it.value());
    }
  return py::make_tuple(py::array(py::cast(r)), py::array(py::cast(c)), py::array(py::cast(v)),
                        py::make_tuple(m.rows(), m.cols()));
}

auto make_parametrization(const IArr& triangles, const DArr& pbar,
                          BoolArr boundary) {
  check_shape(pbar, -1, 2, "pbar");
  const py::ssize_t n = pbar.shape(0);
  check_shape(boundary, n, -1, "boundary");
  std::vector<unsigned char> b(boundary.data(), boundary.data() + n);
  return std::make_unique<opt::Parametrization>(int(n), tris_from(triangles), as<Vec2>(pbar), b.data());
}

auto parametrization_pattern(const opt::Parametrization& p, const DArr& theta) {
  check_shape(theta, p.n_boundary(), 2, "theta");
  return fill_released(p.n_vertices(), 2,
                       [&](double* out) { p.pattern(as<Vec2>(theta), reinterpret_cast<Vec2*>(out)); });
}

auto parametrization_adjoint(const opt::Parametrization& p, const DArr& g) {
  check_shape(g, p.n_vertices(), 2, "g");
  return fill_released(p.n_boundary(), 2,
                       [&](double* out) { p.adjoint(as<Vec2>(g), reinterpret_cast<Vec2*>(out)); });
}

auto harmonic_blocks(const opt::Parametrization& p) {
  py::list out;
  for (const auto& B : p.harmonic_blocks()) {
    DArr M = new_array(int(B.rows.size()), int(B.cols.size()));
    std::copy(B.M.begin(), B.M.end(), M.mutable_data());
    out.append(py::make_tuple(py::array(py::cast(B.rows)), py::array(py::cast(B.cols)), M));
  }
  return out;
}

// Binds Parametrization, p(theta) from the boundary vertices (Eq. 8).
void bind_parametrization(py::module_& m) {
  using opt::Parametrization;
  py::class_<Parametrization>(m, "Parametrization",
                              "Boundary-vertex parametrization of a pattern (Eq. 8), prefactorized.")
      .def(py::init(&make_parametrization), py::arg("triangles"), py::arg("pbar"), py::arg("boundary"),
           "From triangles (T, 3), the base pattern pbar (n, 2) and a per-vertex boundary mask (n,).")
      .def_property_readonly("n_vertices", &Parametrization::n_vertices, "number of pattern vertices")
      .def_property_readonly(
          "boundary_ids", [](const Parametrization& p) { return py::array(py::cast(p.boundary_ids())); },
          "the boundary vertices, in increasing id: the rows of theta")
      .def_property_readonly(
          "interior_ids", [](const Parametrization& p) { return py::array(py::cast(p.interior_ids())); },
          "the interior vertices, in increasing id")
      .def("pattern", &parametrization_pattern, py::arg("theta"), "p(theta): (n_boundary, 2) -> (n_vertices, 2)")
      .def("adjoint", &parametrization_adjoint, py::arg("g"),
           "(dp/dtheta)^T g: (n_vertices, 2) -> (n_boundary, 2)")
      .def(
          "laplacian_triplets", [](const Parametrization& p) { return triplets(p.laplacian()); },
          "The cotangent Laplacian as (rows, cols, values, shape).")
      .def_property_readonly("harmonic_doubles", &Parametrization::harmonic_doubles,
                             "doubles held by harmonic_blocks, summed over the panels")
      .def("harmonic_blocks", &harmonic_blocks,
           "Per panel: (rows into interior_ids, columns into theta, M) with the panel's interior moving by "
           "M (theta - theta_bar)[columns].");
}

auto make_regularizers(const DArr& theta_bar, const std::vector<std::vector<int>>& loops,
                       const DArr& weight) {
  check_shape(theta_bar, -1, 2, "theta_bar");
  check_shape(weight, theta_bar.shape(0), -1, "weight");
  std::vector<Vec2> tb(as<Vec2>(theta_bar), as<Vec2>(theta_bar) + theta_bar.shape(0));
  std::vector<double> w(weight.data(), weight.data() + weight.shape(0));
  return std::make_unique<opt::Regularizers>(tb, loops, w);
}

auto regularizers_evaluate(const opt::Regularizers& r, const DArr& theta) {
  check_shape(theta, r.n_theta(), 2, "theta");
  DArr g = new_array(r.n_theta(), 2);
  std::array<double, 2> t{};
  const double v = r.evaluate(as<Vec2>(theta), as_mut<Vec2>(g), &t);
  return py::make_tuple(v, py::make_tuple(t[0], t[1]), g);
}

auto regularizers_precondition(opt::Regularizers& r, const DArr& g) {
  check_shape(g, r.n_theta(), 2, "g");
  DArr out = new_array(r.n_theta(), 2);
  r.apply_preconditioner(as<Vec2>(g), as_mut<Vec2>(out));
  return out;
}

void regularizers_set_extra_hessian(opt::Regularizers& r, const IArr& rows, const IArr& cols, const DArr& vals) {
  check_shape(rows, -1, -1, "rows");
  check_shape(cols, rows.shape(0), -1, "cols");
  check_shape(vals, rows.shape(0), -1, "vals");
  const int n = 2 * r.n_theta();
  std::vector<Eigen::Triplet<double>> t;
  for (py::ssize_t i = 0; i < rows.shape(0); ++i) {
    const int a = rows.data()[i], b = cols.data()[i];
    if (a < 0 || a >= n || b < 0 || b >= n) throw py::value_error("extra Hessian index out of range");
    t.emplace_back(a, b, vals.data()[i]);
  }
  Eigen::SparseMatrix<double> H;
  if (!t.empty()) {
    H.resize(n, n);
    H.setFromTriplets(t.begin(), t.end());
  }
  r.set_extra_hessian(H);
}

// Binds Regularizers, R^fix and R^cur over theta and their preconditioner P.
void bind_regularizers(py::module_& m) {
  using opt::Regularizers;
  py::class_<Regularizers>(m, "Regularizers", "R^fix (Eq. 9) and R^cur (Eq. 10) over theta, and the preconditioner.")
      .def(py::init(&make_regularizers), py::arg("theta_bar"), py::arg("loops"), py::arg("weight"),
           "From the base boundary theta_bar (n_theta, 2), closed outlines as theta indices, and the "
           "per-entry R^cur weights (n_theta,).")
      .def("set_strengths", &Regularizers::set_strengths, py::arg("delta_fix"), py::arg("delta_cur"),
           "The strengths of R^fix and R^cur (P is refactorized).")
      .def_property_readonly("n_theta", &Regularizers::n_theta, "number of boundary entries in theta")
      .def_property_readonly(
          "curve_elements", [](const Regularizers& r) { return r.curve_elements(); },
          "R^cur's curve elements (j, i, k) as theta indices")
      .def("evaluate", &regularizers_evaluate, py::arg("theta"), "-> (value, (R_fix, R_cur), gradient)")
      .def("apply_preconditioner", &regularizers_precondition, py::arg("g"), "P^-1 g")
      .def(
          "hessian_triplets", [](const Regularizers& r) { return triplets(r.hessian()); },
          "P as (rows, cols, values, shape).")
      .def("set_extra_hessian", &regularizers_set_extra_hessian, py::arg("rows"), py::arg("cols"), py::arg("vals"),
           "constant block added to P (empty: none)");
}

auto make_seam_length(const DArr& theta_bar, const IArr& segments) {
  check_shape(theta_bar, -1, 2, "theta_bar");
  check_shape(segments, -1, 4, "segments");
  std::vector<Vec2> tb(as<Vec2>(theta_bar), as<Vec2>(theta_bar) + theta_bar.shape(0));
  std::vector<opt::SeamSegment> seg(segments.shape(0));
  for (size_t i = 0; i < seg.size(); ++i)
    for (int c = 0; c < 4; ++c) seg[i][c] = segments.data()[4 * i + c];
  return std::make_unique<opt::SeamLength>(tb, seg);
}

auto seam_segments(const opt::SeamLength& s) {
  py::array_t<int> out({py::ssize_t(s.segments().size()), py::ssize_t(4)});
  for (size_t i = 0; i < s.segments().size(); ++i)
    for (int c = 0; c < 4; ++c) out.mutable_data()[4 * i + c] = s.segments()[i][c];
  return out;
}

auto seam_evaluate(const opt::SeamLength& s, const DArr& theta) {
  check_shape(theta, s.n_theta(), 2, "theta");
  DArr g = new_array(s.n_theta(), 2);
  const double v = s.evaluate(as<Vec2>(theta), as_mut<Vec2>(g));
  return py::make_tuple(v, g);
}

// Binds SeamLength, R^seam over theta.
void bind_seam_length(py::module_& m) {
  using opt::SeamLength;
  py::class_<SeamLength>(m, "SeamLength", "R^seam over theta: matched stitch segments keep their base length ratio.")
      .def(py::init(&make_seam_length), py::arg("theta_bar"), py::arg("segments"),
           "From the base boundary theta_bar (n_theta, 2) and matched segments (K, 4): a0 a1 b0 b1 theta indices.")
      .def("set_strength", &SeamLength::set_strength, py::arg("delta_seam"), "The strength of R^seam.")
      .def_property_readonly("n_theta", &SeamLength::n_theta, "number of boundary entries in theta")
      .def_property_readonly("evaluations", &SeamLength::evaluations, "evaluations so far, here and on the GPU")
      .def_property_readonly("segments", &seam_segments, "the kept segments (K, 4), as theta indices")
      .def_property_readonly(
          "ratios", [](const SeamLength& s) { return py::array(py::cast(s.ratios())); },
          "per segment, the base length ratio to keep")
      .def("evaluate", &seam_evaluate, py::arg("theta"), "-> (value, gradient)")
      .def(
          "residuals",
          [](const SeamLength& s, const DArr& theta) {
            check_shape(theta, s.n_theta(), 2, "theta");
            return py::array(py::cast(s.residuals(as<Vec2>(theta))));
          },
          py::arg("theta"), "per segment r (m)")
      .def(
          "gauss_newton_triplets",
          [](const SeamLength& s, const DArr& theta) {
            check_shape(theta, s.n_theta(), 2, "theta");
            return triplets(s.gauss_newton(as<Vec2>(theta)));
          },
          py::arg("theta"), "delta_seam J^T J at theta (Gauss-Newton) as (rows, cols, values, shape)");
}

}  // namespace

// Binds the optimizer's blocks in their order: parametrization, regularizers, the GPU
// copies of the regularizers, the costs.
void bind_opt(py::module_& m) {
  bind_parametrization(m);
  bind_regularizers(m);
  bind_seam_length(m);
#ifdef SEAMFIT_WITH_CUDA
  bind_opt_cuda(m);
#endif
  bind_opt_costs(m);
}

}  // namespace seamfit::bindings
