// Python bindings of the fitting costs (Eq. 11-16) and the queries that prepare
// them: SDF sampling of the target body and the transfer of the base garment.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
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

// The registered term called name, or ValueError listing them.
opt::CostTerm cost_term(const std::string& name) {
  const opt::CostTerm t = opt::cost_term_named(name.c_str());
  if (t == opt::kNumCostTerms) {
    std::string known;
    for (const auto& info : opt::kCostTerms) known += std::string(known.empty() ? "" : ", ") + info.name;
    throw py::value_error("unknown cost term '" + name + "'; the terms are " + known);
  }
  return t;
}

void cost_set_strengths(PyCostSet& c, const py::dict& strengths) {
  opt::CostStrengths s{};
  for (const auto& item : strengths) s[cost_term(py::cast<std::string>(item.first))] = py::cast<double>(item.second);
  c.cs->set_strengths(s);
}

void cost_set_target_sdf(PyCostSet& c, const FArr& values, const DArr& origin, double spacing) {
  const SdfGridView g = grid_view(values, origin, spacing);
  try {
    c.cs->set_target_sdf(g);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  c.sdf_values = values;  // keep the grid alive for the view
}

void cost_set_inputs(PyCostSet& c, const std::string& name, const DArr& values) {
  const opt::CostTerm t = cost_term(name);
  const int width = c.cs->width(t);
  check_shape(values, c.cs->elements(t).count, width == 1 ? -1 : width, name.c_str());
  try {
    c.cs->set_inputs(t, values.data());
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
}

// Rows of cols ints or doubles as a new (rows, cols) array.
template <class V>
py::array_t<V> rows_array(const std::vector<V>& v, int cols) {
  py::array_t<V> a({py::ssize_t(cols ? v.size() / cols : 0), py::ssize_t(cols)});
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

// (name, label, help) per registered term, in registry order.
py::tuple cost_terms_table() {
  py::list out;
  for (const auto& info : opt::kCostTerms) out.append(py::make_tuple(info.name, info.label, info.help));
  return py::tuple(out);
}

auto cost_set_evaluate(PyCostSet& c, const DArr& x, const DArr& p) {
  const int n = c.cs->n_vertices();
  check_shape(x, n, 3, "x");
  check_shape(p, n, 2, "p");
  DArr gx = new_array(n, 3), gp = new_array(n, 2);
  opt::CostValues t{};
  double v;
  try {
    py::gil_scoped_release nogil;
    v = c.cs->evaluate(as<Vec3>(x), as<Vec2>(p), as_mut<Vec3>(gx), as_mut<Vec2>(gp), &t);
  } catch (const std::logic_error& e) {
    throw py::value_error(e.what());
  }
  return py::make_tuple(v, cost_terms_dict(t), gx, gp);
}


// Binds CostSet, the fitting costs on the CPU.
void bind_cost_set(py::module_& m) {
  py::class_<PyCostSet>(m, "CostSet", "Fitting costs (Eq. 11-16) on the CPU.")
      .def(py::init(&make_cost_set), py::arg("triangles"), py::arg("pbar"), py::arg("xbar"),
           "From triangles (T, 3), the base pattern pbar (n, 2) and the base garment xbar (n, 3).")
      .def("set_strengths", &cost_set_strengths, py::arg("strengths"),
           "{name: strength} of the terms in COST_TERMS; a term left out gets 0.")
      .def("set_target_sdf", &cost_set_target_sdf, py::arg("values"), py::arg("origin"), py::arg("spacing"),
           "The target body's SDF grid (kept alive here), for the terms that sample it.")
      .def("set_inputs", &cost_set_inputs, py::arg("name"), py::arg("values"),
           "The constants of the term called name, where it takes them from the caller: one row of its "
           "width per element (a 1-D array for width 1).")
      .def("evaluate", &cost_set_evaluate, py::arg("x"), py::arg("p"), "-> (value, terms, grad_x, grad_p)")
      .def_property_readonly(
          "evaluations", [](const PyCostSet& c) { return cost_terms_dict(c.cs->evaluations()); },
          "evaluations so far per term")
      .def_property_readonly(
          "edges", [](const PyCostSet& c) { return rows_array(c.cs->elements(opt::kEdges).ids, 2); },
          "the mesh edges as vertex pairs")
      .def_property_readonly(
          "hinges", [](const PyCostSet& c) { return rows_array(c.cs->elements(opt::kHinges).ids, 4); },
          "the interior hinges as 4 vertices")
      .def(
          "constants",
          [](const PyCostSet& c, const std::string& name) {
            const opt::CostTerm t = cost_term(name);
            return rows_array(c.cs->constants(t), c.cs->width(t));
          },
          py::arg("name"), "a term's constants, one row per element (empty before its inputs are set)");
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
  m.attr("COST_TERMS") = cost_terms_table();
  bind_cost_set(m);
  m.def("sdf_sample_grid", &sdf_sample_grid, py::arg("values"), py::arg("origin"), py::arg("spacing"),
        py::arg("points"), "Trilinear SDF value and gradient (the interpolant the costs and the simulator use).");
  m.def("transfer_query", &transfer_query, py::arg("verts"), py::arg("faces"), py::arg("points"),
        py::arg("bandwidth"), "Closest body triangle and second local minimum per point (Eq. 15 inputs).");
}

}  // namespace seamfit::bindings
