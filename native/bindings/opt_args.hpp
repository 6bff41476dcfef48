// Shape checks and array views shared by the optimizer's bindings (opt.cpp,
// opt_costs.cpp, opt_cuda.cpp). Failures raise ValueError.
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "body/sdf_grid.hpp"
#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::bindings::opt_args {

namespace py = pybind11;

using opt::Tri;
using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IArr = py::array_t<int, py::array::c_style | py::array::forcecast>;
using FArr = py::array_t<float, py::array::c_style | py::array::forcecast>;
// as<Vec3> / as<Vec2> reinterpret rows of doubles.
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Vec2) == 2 * sizeof(double), "packed vectors");

// rows < 0: any row count; cols < 0: a 1-D array.
inline void check_shape(const py::array& a, py::ssize_t rows, py::ssize_t cols, const char* name) {
  const bool ok = (cols < 0) ? (a.ndim() == 1 && (rows < 0 || a.shape(0) == rows))
                             : (a.ndim() == 2 && (rows < 0 || a.shape(0) == rows) && a.shape(1) == cols);
  if (!ok) {
    std::string want = cols < 0 ? "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ",)"
                                : "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ", " +
                                      std::to_string(cols) + ")";
    throw py::value_error(std::string(name) + ": expected an array of shape " + want);
  }
}

inline std::vector<Tri> tris_from(const IArr& t) {
  check_shape(t, -1, 3, "triangles");
  std::vector<Tri> out(t.shape(0));
  const int* d = t.data();
  for (size_t i = 0; i < out.size(); ++i) out[i] = {d[3 * i], d[3 * i + 1], d[3 * i + 2]};
  return out;
}

template <class V>
const V* as(const DArr& a) { return reinterpret_cast<const V*>(a.data()); }

template <class V>
V* as_mut(DArr& a) { return reinterpret_cast<V*>(a.mutable_data()); }

// cols < 0: a 1-D array of rows entries.
inline DArr new_array(py::ssize_t rows, py::ssize_t cols) {
  return cols < 0 ? DArr({rows}) : DArr({rows, cols});
}

// A non-owning view of a (nz, ny, nx) float32 grid: the caller keeps values alive.
inline SdfGridView grid_view(const FArr& values, const DArr& origin, double spacing) {
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

}  // namespace seamfit::bindings::opt_args
