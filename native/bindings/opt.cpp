// Python bindings of the optimizer's building blocks (native/core/opt). Thin: shape
// checks and array conversion only; seamfit.opt wraps these in the public API.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "finite_check.hpp"
#include "py_cost_set.hpp"
#include "body/sdf_grid.hpp"
#include "opt/cost_set.hpp"
#include "opt/parametrization.hpp"
#include "opt/regularizer_set.hpp"
#include "opt/seam_length.hpp"
#include "opt/transfer.hpp"
#ifdef SEAMFIT_WITH_CUDA
#include "py_device_array.hpp"
#include "regularizers_gpu.hpp"
#endif

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using opt::Tri;
using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IArr = py::array_t<int, py::array::c_style | py::array::forcecast>;
using FArr = py::array_t<float, py::array::c_style | py::array::forcecast>;
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Vec2) == 2 * sizeof(double), "packed vectors");

void check_shape(const py::array& a, py::ssize_t rows, py::ssize_t cols, const char* name) {
  const bool ok = (cols < 0) ? (a.ndim() == 1 && (rows < 0 || a.shape(0) == rows))
                             : (a.ndim() == 2 && (rows < 0 || a.shape(0) == rows) && a.shape(1) == cols);
  if (!ok) {
    std::string want = cols < 0 ? "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ",)"
                                : "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ", " +
                                      std::to_string(cols) + ")";
    throw py::value_error(std::string(name) + ": expected an array of shape " + want);
  }
}

std::vector<Tri> tris_from(const IArr& t) {
  check_shape(t, -1, 3, "triangles");
  std::vector<Tri> out(t.shape(0));
  const int* d = t.data();
  for (size_t i = 0; i < out.size(); ++i) out[i] = {d[3 * i], d[3 * i + 1], d[3 * i + 2]};
  return out;
}

template <class V>
const V* as(const DArr& a) { return reinterpret_cast<const V*>(a.data()); }

DArr new_array(py::ssize_t rows, py::ssize_t cols) {
  return cols < 0 ? DArr({rows}) : DArr({rows, cols});
}

template <class V>
V* as_mut(DArr& a) { return reinterpret_cast<V*>(a.mutable_data()); }

SdfGridView grid_view(const FArr& values, const DArr& origin, double spacing) {
  if (values.ndim() != 3) throw py::value_error("sdf values: expected a (nz, ny, nx) array");
  check_shape(origin, 3, -1, "sdf origin");
  SdfGridView g;
  g.values = values.data();
  g.nz = int(values.shape(0));
  g.ny = int(values.shape(1));
  g.nx = int(values.shape(2));
  for (int a = 0; a < 3; ++a) g.origin[a] = origin.data()[a];
  g.spacing = spacing;
  return g;
}


py::dict hits_to_dict(const std::vector<opt::TransferHit>& hits) {
  const py::ssize_t n = py::ssize_t(hits.size());
  py::array_t<int> t0({n}), t1({n});
  DArr d0({n}), d1({n}), b0({n, py::ssize_t(3)}), b1({n, py::ssize_t(3)});
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& h = hits[i];
    t0.mutable_data()[i] = h.t0;
    t1.mutable_data()[i] = h.t1;
    d0.mutable_data()[i] = h.d0;
    d1.mutable_data()[i] = h.d1;
    for (int a = 0; a < 3; ++a) {
      b0.mutable_data()[3 * i + a] = h.b0[a];
      b1.mutable_data()[3 * i + a] = h.b1[a];
    }
  }
  py::dict d;
  d["t0"] = t0; d["d0"] = d0; d["b0"] = b0;
  d["t1"] = t1; d["d1"] = d1; d["b1"] = b1;
  return d;
}

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

}  // namespace

void bind_opt(py::module_& m) {
  py::class_<opt::Parametrization>(m, "Parametrization",
                                   "Boundary-vertex parametrization of a pattern (Eq. 8), prefactorized.")
      .def(py::init([](const IArr& triangles, const DArr& pbar, py::array_t<bool, py::array::c_style | py::array::forcecast> boundary) {
             check_shape(pbar, -1, 2, "pbar");
             const py::ssize_t n = pbar.shape(0);
             check_shape(boundary, n, -1, "boundary");
             std::vector<unsigned char> b(boundary.data(), boundary.data() + n);
             try {
               return std::make_unique<opt::Parametrization>(int(n), tris_from(triangles), as<Vec2>(pbar), b.data());
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
           }),
           py::arg("triangles"), py::arg("pbar"), py::arg("boundary"))
      .def_property_readonly("n_vertices", &opt::Parametrization::n_vertices)
      .def_property_readonly("boundary_ids", [](const opt::Parametrization& p) { return py::array(py::cast(p.boundary_ids())); })
      .def_property_readonly("interior_ids", [](const opt::Parametrization& p) { return py::array(py::cast(p.interior_ids())); })
      .def("pattern", [](const opt::Parametrization& p, const DArr& theta) {
             check_shape(theta, p.n_boundary(), 2, "theta");
             DArr out = new_array(p.n_vertices(), 2);
             {
               py::gil_scoped_release nogil;
               p.pattern(as<Vec2>(theta), as_mut<Vec2>(out));
             }
             return out;
           }, py::arg("theta"), "p(theta): (n_boundary, 2) -> (n_vertices, 2)")
      .def("adjoint", [](const opt::Parametrization& p, const DArr& g) {
             check_shape(g, p.n_vertices(), 2, "g");
             DArr out = new_array(p.n_boundary(), 2);
             {
               py::gil_scoped_release nogil;
               p.adjoint(as<Vec2>(g), as_mut<Vec2>(out));
             }
             return out;
           }, py::arg("g"), "(dp/dtheta)^T g: (n_vertices, 2) -> (n_boundary, 2)")
      .def("laplacian_triplets", [](const opt::Parametrization& p) { return triplets(p.laplacian()); })
      .def_property_readonly("harmonic_doubles", &opt::Parametrization::harmonic_doubles)
      .def("harmonic_blocks", [](const opt::Parametrization& p) {
             py::list out;
             for (const auto& B : p.harmonic_blocks()) {
               DArr M = new_array(int(B.rows.size()), int(B.cols.size()));
               std::copy(B.M.begin(), B.M.end(), M.mutable_data());
               out.append(py::make_tuple(py::array(py::cast(B.rows)), py::array(py::cast(B.cols)), M));
             }
             return out;
           }, "Per panel: (rows into interior_ids, columns into theta, M) with the panel's interior moving by "
              "M (theta - theta_bar)[columns].");

  py::class_<opt::Regularizers>(m, "Regularizers", "R^fix (Eq. 9) and R^cur (Eq. 10) over theta, and the preconditioner.")
      .def(py::init([](const DArr& theta_bar, const std::vector<std::vector<int>>& loops, const DArr& weight) {
             check_shape(theta_bar, -1, 2, "theta_bar");
             check_shape(weight, theta_bar.shape(0), -1, "weight");
             std::vector<Vec2> tb(as<Vec2>(theta_bar), as<Vec2>(theta_bar) + theta_bar.shape(0));
             std::vector<double> w(weight.data(), weight.data() + weight.shape(0));
             try {
               return std::make_unique<opt::Regularizers>(tb, loops, w);
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
           }),
           py::arg("theta_bar"), py::arg("loops"), py::arg("weight"))
      .def("set_strengths", [](opt::Regularizers& r, double fix, double cur) {
             try { r.set_strengths(fix, cur); } catch (const std::invalid_argument& e) { throw py::value_error(e.what()); }
           }, py::arg("delta_fix"), py::arg("delta_cur"))
      .def_property_readonly("n_theta", &opt::Regularizers::n_theta)
      .def_property_readonly("curve_elements", [](const opt::Regularizers& r) { return r.curve_elements(); })
      .def("evaluate", [](const opt::Regularizers& r, const DArr& theta) {
             check_shape(theta, r.n_theta(), 2, "theta");
             DArr g = new_array(r.n_theta(), 2);
             std::array<double, 2> t{};
             const double v = r.evaluate(as<Vec2>(theta), as_mut<Vec2>(g), &t);
             return py::make_tuple(v, py::make_tuple(t[0], t[1]), g);
           }, py::arg("theta"), "-> (value, (R_fix, R_cur), gradient)")
      .def("apply_preconditioner", [](opt::Regularizers& r, const DArr& g) {
             check_shape(g, r.n_theta(), 2, "g");
             DArr out = new_array(r.n_theta(), 2);
             try {
               r.apply_preconditioner(as<Vec2>(g), as_mut<Vec2>(out));
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
             return out;
           }, py::arg("g"), "P^-1 g")
      .def("hessian_triplets", [](const opt::Regularizers& r) { return triplets(r.hessian()); })
      .def("set_extra_hessian", [](opt::Regularizers& r, const IArr& rows, const IArr& cols, const DArr& vals) {
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
           }, py::arg("rows"), py::arg("cols"), py::arg("vals"), "constant block added to P (empty: none)");

  py::class_<opt::SeamLength>(m, "SeamLength", "R^seam over theta: matched stitch segments keep their base length ratio.")
      .def(py::init([](const DArr& theta_bar, const IArr& segments) {
             check_shape(theta_bar, -1, 2, "theta_bar");
             check_shape(segments, -1, 4, "segments");
             std::vector<Vec2> tb(as<Vec2>(theta_bar), as<Vec2>(theta_bar) + theta_bar.shape(0));
             std::vector<opt::SeamSegment> seg(segments.shape(0));
             for (size_t i = 0; i < seg.size(); ++i)
               for (int c = 0; c < 4; ++c) seg[i][c] = segments.data()[4 * i + c];
             try {
               return std::make_unique<opt::SeamLength>(tb, seg);
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
           }),
           py::arg("theta_bar"), py::arg("segments"))
      .def("set_strength", [](opt::SeamLength& s, double d) {
             try { s.set_strength(d); } catch (const std::invalid_argument& e) { throw py::value_error(e.what()); }
           }, py::arg("delta_seam"))
      .def_property_readonly("n_theta", &opt::SeamLength::n_theta)
      .def_property_readonly("evaluations", &opt::SeamLength::evaluations)
      .def_property_readonly("segments", [](const opt::SeamLength& s) {
             py::array_t<int> out({py::ssize_t(s.segments().size()), py::ssize_t(4)});
             for (size_t i = 0; i < s.segments().size(); ++i)
               for (int c = 0; c < 4; ++c) out.mutable_data()[4 * i + c] = s.segments()[i][c];
             return out;
           })
      .def_property_readonly("ratios", [](const opt::SeamLength& s) { return py::array(py::cast(s.ratios())); })
      .def("evaluate", [](const opt::SeamLength& s, const DArr& theta) {
             check_shape(theta, s.n_theta(), 2, "theta");
             DArr g = new_array(s.n_theta(), 2);
             const double v = s.evaluate(as<Vec2>(theta), as_mut<Vec2>(g));
             return py::make_tuple(v, g);
           }, py::arg("theta"), "-> (value, gradient)")
      .def("residuals", [](const opt::SeamLength& s, const DArr& theta) {
             check_shape(theta, s.n_theta(), 2, "theta");
             return py::array(py::cast(s.residuals(as<Vec2>(theta))));
           }, py::arg("theta"), "per segment r (m)")
      .def("gauss_newton_triplets", [](const opt::SeamLength& s, const DArr& theta) {
             check_shape(theta, s.n_theta(), 2, "theta");
             return triplets(s.gauss_newton(as<Vec2>(theta)));
           }, py::arg("theta"));

#ifdef SEAMFIT_WITH_CUDA
  // GPU copies of the two classes above (CudaError -> seamfit.errors.DeviceError, bind_cuda_sim).
  using cuda::RegularizersGpu;
  py::class_<RegularizersGpu>(m, "CudaRegularizers",
                              "R^fix + R^cur and P^-1 g on the GPU (P^-1 dense, rebuilt when P changes).")
      .def(py::init([](const opt::Regularizers& objective, opt::Regularizers& precond, size_t max_bytes) {
             try {
               return std::make_unique<RegularizersGpu>(objective, precond, max_bytes);
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
           }),
           py::arg("objective"), py::arg("precond"), py::arg("max_bytes"),
           py::keep_alive<1, 2>(), py::keep_alive<1, 3>())  // the CPU objects hold the strengths and P
      .def_static("inverse_bytes", &RegularizersGpu::inverse_bytes, py::arg("n_theta"),
                  "device bytes of P^-1 for n_theta boundary entries")
      .def("evaluate", [](RegularizersGpu& g, const DArr& theta) {
             check_shape(theta, g.n_theta(), 2, "theta");
             DArr grad = new_array(g.n_theta(), 2);
             std::array<double, 2> t{};
             const double v = g.evaluate(as<Vec2>(theta), as_mut<Vec2>(grad), &t);
             return py::make_tuple(v, py::make_tuple(t[0], t[1]), grad);
           }, py::arg("theta"), "-> (value, (R_fix, R_cur), gradient), as Regularizers.evaluate")
      .def("apply_preconditioner", [](RegularizersGpu& g, const DArr& grad) {
             check_shape(grad, g.n_theta(), 2, "g");
             DArr out = new_array(g.n_theta(), 2);
             try {
               g.apply_preconditioner(as<Vec2>(grad), as_mut<Vec2>(out));
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
             return out;
           }, py::arg("g"), "P^-1 g")
      .def("evaluate_device", [](RegularizersGpu& g, const cuda::DeviceArray& theta, cuda::DeviceArray& grad) {
             require_shape(theta, g.n_theta(), 2, "theta");
             require_shape(grad, g.n_theta(), 2, "grad");
             std::array<double, 2> t{};
             const double v = g.evaluate_device(theta.data(), grad.data(), &t);
             return py::make_tuple(v, py::make_tuple(t[0], t[1]));
           }, py::arg("theta"), py::arg("grad"), "-> (value, (R_fix, R_cur)); the gradient into grad (DeviceArrays)")
      .def("apply_preconditioner_device", [](RegularizersGpu& g, const cuda::DeviceArray& grad, cuda::DeviceArray& out) {
             require_shape(grad, g.n_theta(), 2, "g");
             require_shape(out, g.n_theta(), 2, "out");
             try {
               g.apply_preconditioner_device(grad.data(), out.data());
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
           }, py::arg("g"), py::arg("out"), "out = P^-1 g (DeviceArrays)")
      .def_property_readonly("device_bytes", &RegularizersGpu::device_bytes)
      .def_property_readonly("inverse_builds", &RegularizersGpu::inverse_builds);

  using cuda::SeamLengthGpu;
  py::class_<SeamLengthGpu>(m, "CudaSeamLength", "R^seam and its gradient on the GPU, mirroring a SeamLength.")
      .def(py::init([](const opt::SeamLength& s) { return std::make_unique<SeamLengthGpu>(s); }), py::arg("seam"),
           py::keep_alive<1, 2>())  // the CPU object holds the strength and the evaluation count
      .def("evaluate", [](SeamLengthGpu& g, const DArr& theta) {
             check_shape(theta, g.n_theta(), 2, "theta");
             DArr grad = new_array(g.n_theta(), 2);
             const double v = g.evaluate(as<Vec2>(theta), as_mut<Vec2>(grad));
             return py::make_tuple(v, grad);
           }, py::arg("theta"), "-> (value, gradient), as SeamLength.evaluate")
      .def("evaluate_device", [](SeamLengthGpu& g, const cuda::DeviceArray& theta, cuda::DeviceArray& grad) {
             require_shape(theta, g.n_theta(), 2, "theta");
             require_shape(grad, g.n_theta(), 2, "grad");
             return g.evaluate_device(theta.data(), grad.data());
           }, py::arg("theta"), py::arg("grad"), "-> value; the gradient into grad (DeviceArrays)");
#endif

  py::class_<PyCostSet>(m, "CostSet", "Fitting costs (Eq. 11-16) on the CPU.")
      .def(py::init([](const IArr& triangles, const DArr& pbar, const DArr& xbar) {
             check_shape(pbar, -1, 2, "pbar");
             check_shape(xbar, pbar.shape(0), 3, "xbar");
             auto out = std::make_unique<PyCostSet>();
             try {
               out->cs = std::make_unique<opt::CostSet>(int(pbar.shape(0)), tris_from(triangles), as<Vec2>(pbar),
                                                        as<Vec3>(xbar));
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
             return out;
           }),
           py::arg("triangles"), py::arg("pbar"), py::arg("xbar"))
      .def("set_strengths", [](PyCostSet& c, double dis, double smo, double str, double pos) {
             c.cs->set_strengths({dis, smo, str, pos});
           }, py::arg("dis"), py::arg("smo"), py::arg("str"), py::arg("pos"))
      .def("set_distance", [](PyCostSet& c, const FArr& values, const DArr& origin, double spacing, const DArr& phibar) {
             check_shape(phibar, c.cs->n_vertices(), -1, "phibar");
             const SdfGridView g = grid_view(values, origin, spacing);
             try {
               c.cs->set_distance(g, phibar.data());
             } catch (const std::invalid_argument& e) {
               throw py::value_error(e.what());
             }
             c.sdf_values = values;  // keep the grid alive for the view
           }, py::arg("values"), py::arg("origin"), py::arg("spacing"), py::arg("phibar"))
      .def("set_positional", [](PyCostSet& c, const DArr& xtilde, const DArr& u) {
             check_shape(xtilde, c.cs->n_vertices(), 3, "xtilde");
             check_shape(u, c.cs->n_vertices(), -1, "u");
             c.cs->set_positional(as<Vec3>(xtilde), u.data());
           }, py::arg("xtilde"), py::arg("u"))
      .def("evaluate", [](PyCostSet& c, const DArr& x, const DArr& p) {
             const int n = c.cs->n_vertices();
             check_shape(x, n, 3, "x");
             check_shape(p, n, 2, "p");
             DArr gx = new_array(n, 3), gp = new_array(n, 2);
             std::array<double, opt::kNumCostTerms> t{};
             double v;
             try {
               py::gil_scoped_release nogil;
               v = c.cs->evaluate(as<Vec3>(x), as<Vec2>(p), as_mut<Vec3>(gx), as_mut<Vec2>(gp), &t);
             } catch (const std::logic_error& e) {
               throw py::value_error(e.what());
             }
             return py::make_tuple(v, cost_terms_dict(t), gx, gp);
           }, py::arg("x"), py::arg("p"), "-> (value, terms, grad_x, grad_p)")
      .def_property_readonly("evaluations", [](const PyCostSet& c) {
             const auto& e = c.cs->evaluations();
             py::dict d;
             d["dis"] = e[opt::kDistance];
             d["smo"] = e[opt::kSmoothness];
             d["str"] = e[opt::kStretching];
             d["pos"] = e[opt::kPositional];
             return d;
           })
      .def_property_readonly("edges", [](const PyCostSet& c) { return c.cs->edges(); })
      .def_property_readonly("hinges", [](const PyCostSet& c) { return c.cs->hinges(); })
      .def_property_readonly("hinge_weights", [](const PyCostSet& c) { return c.cs->hinge_weights(); })
      .def_property_readonly("stretch_ratio_bar", [](const PyCostSet& c) { return c.cs->stretch_ratio_bar(); });

  m.def("sdf_sample_grid", [](const FArr& values, const DArr& origin, double spacing, const DArr& points) {
          check_shape(points, -1, 3, "points");
          const SdfGridView g = grid_view(values, origin, spacing);
          require_finite_rows(origin.data(), 1, 3, "sdf origin");
          if (!(spacing > 0) || !std::isfinite(spacing)) throw py::value_error("sdf spacing must be a positive number");
          const py::ssize_t n = points.shape(0);
          require_finite_rows(points.data(), n, 3, "points");
          DArr phi = new_array(n, -1), grad = new_array(n, 3);
          const Vec3* p = as<Vec3>(points);
          for (py::ssize_t i = 0; i < n; ++i) {
            const SdfSample s = sdf_sample(g, p[i]);
            phi.mutable_data()[i] = s.phi;
            as_mut<Vec3>(grad)[i] = s.grad;
          }
          require_finite_samples(phi.data(), grad.data(), n);
          return py::make_tuple(phi, grad);
        }, py::arg("values"), py::arg("origin"), py::arg("spacing"), py::arg("points"),
        "Trilinear SDF value and gradient (the interpolant the costs and the simulator use).");

  m.def("transfer_query", [](const DArr& verts, const IArr& faces, const DArr& points, double bandwidth) {
          check_shape(verts, -1, 3, "body vertices");
          check_shape(points, -1, 3, "points");
          require_finite_rows(verts.data(), verts.shape(0), 3, "body vertices");
          require_finite_rows(points.data(), points.shape(0), 3, "points");
          std::vector<Vec3> v(as<Vec3>(verts), as<Vec3>(verts) + verts.shape(0));
          std::vector<Vec3> q(as<Vec3>(points), as<Vec3>(points) + points.shape(0));
          const auto f = tris_from(faces);
          std::vector<opt::TransferHit> hits;
          try {
            py::gil_scoped_release nogil;
            hits = opt::transfer_query(v, f, q, bandwidth);
          } catch (const std::invalid_argument& e) {
            throw py::value_error(e.what());
          }
          return hits_to_dict(hits);
        }, py::arg("verts"), py::arg("faces"), py::arg("points"), py::arg("bandwidth"),
        "Closest body triangle and second local minimum per point (Eq. 15 inputs).");
}

}  // namespace seamfit::bindings
