// Python bindings of the fitting costs (Eq. 11-16) and the queries that prepare
// them: SDF sampling of the target body and the transfer of the base garment.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "bindings.hpp"
#include "finite_check.hpp"
#include "opt/cost_set.hpp"
#include "opt/transfer.hpp"
#include "opt_args.hpp"
#include "py_cost_set.hpp"

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using namespace opt_args;

auto make_cost_set(const IArr& triangles, const DArr& pbar, const DArr& xbar) {
  check_shape(pbar, -1, 2, "pbar");
  check_shape(xbar, pbar.shape(0), 3, "xbar");
  auto out = std::make_unique<PyCostSet>();
  try {
    out->cs = std::make_unique<opt::CostSet>(int(pbar.shape(0)), tris_from(triangles), as<Vec2>(pbar), as<Vec3>(xbar));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return out;
}

void cost_set_distance(PyCostSet& c, const FArr& values, const DArr& origin, double spacing, const DArr& phibar) {
  check_shape(phibar, c.cs->n_vertices(), -1, "phibar");
  const SdfGridView g = grid_view(values, origin, spacing);
  try {
    c.cs->set_distance(g, phibar.data());
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  c.sdf_values = values;  // keep the grid alive for the view
}

void cost_set_positional(PyCostSet& c, const DArr& xtilde, const DArr& u) {
  check_shape(xtilde, c.cs->n_vertices(), 3, "xtilde");
  check_shape(u, c.cs->n_vertices(), -1, "u");
  c.cs->set_positional(as<Vec3>(xtilde), u.data());
}

auto cost_set_evaluate(PyCostSet& c, const DArr& x, const DArr& p) {
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
}

auto cost_set_evaluations(const PyCostSet& c) {
  const auto& e = c.cs->evaluations();
  py::dict d;
  d["dis"] = e[opt::kDistance];
  d["smo"] = e[opt::kSmoothness];
  d["str"] = e[opt::kStretching];
  d["pos"] = e[opt::kPositional];
  return d;
}

// Binds CostSet, the fitting costs on the CPU.
void bind_cost_set(py::module_& m) {
  py::class_<PyCostSet>(m, "CostSet", "Fitting costs (Eq. 11-16) on the CPU.")
      .def(py::init(&make_cost_set), py::arg("triangles"), py::arg("pbar"), py::arg("xbar"),
           "From triangles (T, 3), the base pattern pbar (n, 2) and the base garment xbar (n, 3).")
      .def(
          "set_strengths",
          [](PyCostSet& c, double dis, double smo, double str, double pos) {
            c.cs->set_strengths({dis, smo, str, pos});
          },
          py::arg("dis"), py::arg("smo"), py::arg("str"), py::arg("pos"),
          "Strengths of the distance, smoothness, stretching and positional terms.")
      .def("set_distance", &cost_set_distance, py::arg("values"), py::arg("origin"), py::arg("spacing"),
           py::arg("phibar"),
           "The target body's SDF grid (kept alive here) and the base garment's distances phibar (n,).")
      .def("set_positional", &cost_set_positional, py::arg("xtilde"), py::arg("u"),
           "The transferred garment xtilde (n, 3) (Eq. 15) and per-vertex weights u (n,).")
      .def("evaluate", &cost_set_evaluate, py::arg("x"), py::arg("p"), "-> (value, terms, grad_x, grad_p)")
      .def_property_readonly("evaluations", &cost_set_evaluations, "evaluations so far per term")
      .def_property_readonly(
          "edges", [](const PyCostSet& c) { return c.cs->edges(); }, "the mesh edges as vertex pairs")
      .def_property_readonly(
          "hinges", [](const PyCostSet& c) { return c.cs->hinges(); }, "the interior hinges as 4 vertices")
      .def_property_readonly(
          "hinge_weights", [](const PyCostSet& c) { return c.cs->hinge_weights(); },
          "the smoothness weights of each hinge's 4 vertices")
      .def_property_readonly(
          "stretch_ratio_bar", [](const PyCostSet& c) { return c.cs->stretch_ratio_bar(); },
          "per edge, the base garment's stretch ratio");
}

auto sdf_sample_grid(const FArr& values, const DArr& origin, double spacing, const DArr& points) {
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

auto transfer_query(const DArr& verts, const IArr& faces, const DArr& points, double bandwidth) {
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
}

}  // namespace

// Binds the costs: CostSet, then the SDF sampling and transfer queries.
void bind_opt_costs(py::module_& m) {
  bind_cost_set(m);
  m.def("sdf_sample_grid", &sdf_sample_grid, py::arg("values"), py::arg("origin"), py::arg("spacing"),
        py::arg("points"), "Trilinear SDF value and gradient (the interpolant the costs and the simulator use).");
  m.def("transfer_query", &transfer_query, py::arg("verts"), py::arg("faces"), py::arg("points"),
        py::arg("bandwidth"), "Closest body triangle and second local minimum per point (Eq. 15 inputs).");
}

}  // namespace seamfit::bindings
