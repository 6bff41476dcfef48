// Bodies: signed distance field build and batch sampling.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "finite_check.hpp"
#include "body/sdf_build.hpp"
#include "body/sdf_grid.hpp"
#ifdef SEAMFIT_WITH_CUDA
#include "body/sdf_gpu.hpp"
#include "device/device_info.hpp"
#include "device/cuda_error.hpp"
#endif

namespace py = pybind11;

namespace seamfit::bindings {
namespace {

using F64 = py::array_t<double, py::array::c_style | py::array::forcecast>;
using F32 = py::array_t<float, py::array::c_style | py::array::forcecast>;
using I32 = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;

void need_n3(const py::array& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3) throw std::invalid_argument(std::string(what) + " must have shape (n, 3)");
}

body::SdfBuildParams make_params(double spacing, double padding, const py::object& bounds, double band, int rounds, int threads) {
  body::SdfBuildParams p;
  p.spacing = spacing;
  p.padding = padding;
  p.band = band;
  p.rounds = rounds;
  p.threads = threads;
  if (!bounds.is_none()) {
    F64 b = py::cast<F64>(bounds);
    if (b.size() != 6) throw std::invalid_argument("bounds must be 6 numbers: (xmin, ymin, zmin, xmax, ymax, zmax)");
    const double* d = b.data();
    p.has_bounds = true;
    for (int a = 0; a < 3; ++a) { p.bounds_lo[a] = d[a]; p.bounds_hi[a] = d[3 + a]; }
  }
  if (!(band >= 1.0)) throw std::invalid_argument("band must be at least 1 cell");
  if (rounds < 1) throw std::invalid_argument("rounds must be >= 1");
  return p;
}

// "cpu", or "cuda" where this build has the CUDA backend and a GPU is present.
void set_device(body::SdfBuildParams& p, const std::string& device) {
  if (device == "cpu") return;
  if (device != "cuda") throw std::invalid_argument("unknown device '" + device + "' (cpu or cuda)");
#ifdef SEAMFIT_WITH_CUDA
  if (cuda::device_count() == 0)
    throw cuda::CudaError("device cuda: no CUDA GPU or driver is present on this machine");
  p.gpu = true;
  p.gpu_distances = &cuda::sdf_gpu_distances;
#else
  throw std::invalid_argument("device cuda: this seamfit build has no CUDA backend (it was built without nvcc)");
#endif
}

py::dict layout_dict(const body::SdfLayout& L) {
  py::dict d;
  d["origin"] = py::make_tuple(L.origin[0], L.origin[1], L.origin[2]);
  d["dims"] = py::make_tuple(L.dims[0], L.dims[1], L.dims[2]);
  return d;
}

auto sdf_layout(F64 vertices, double spacing, double padding, py::object bounds) {
  need_n3(vertices, "vertices");
  auto p = make_params(spacing, padding, bounds, 1.5, 1, 0);
  return layout_dict(body::sdf_layout(vertices.data(), vertices.shape(0), p));
}

// The build's layout, timings and counters, as sdf_build returns them.
py::dict build_info(const body::SdfLayout& L, const body::SdfBuildStats& st, double spacing,
                    const std::string& device) {
  using namespace py::literals;
  return py::dict(**layout_dict(L), "spacing"_a = spacing, "device"_a = device,
                  "seconds_total"_a = st.seconds_total, "seconds_band"_a = st.seconds_band,
                  "seconds_seed"_a = st.seconds_seed, "seconds_propagate"_a = st.seconds_propagate,
                  "seconds_sign"_a = st.seconds_sign, "seconds_gpu"_a = st.seconds_gpu,
                  "band_evaluations"_a = st.band_evaluations, "propagate_evaluations"_a = st.propagate_evaluations,
                  "seeded_nodes"_a = st.seeded_nodes, "cap_winding_nodes"_a = st.cap_winding_nodes,
                  "boundary_edges"_a = st.boundary_edges, "caps"_a = st.caps, "inside_nodes"_a = st.inside_nodes,
                  "threads"_a = st.threads);
}

auto sdf_build(F64 vertices, I32 faces, double spacing, double padding, py::object bounds, double band,
               int rounds, int threads, int64_t max_nodes, const std::string& device) {
  need_n3(vertices, "vertices");
  need_n3(faces, "faces");
  auto p = make_params(spacing, padding, bounds, band, rounds, threads);
  set_device(p, device);
  body::SdfLayout L = body::sdf_layout(vertices.data(), vertices.shape(0), p);
  if (L.nodes() > max_nodes)
    throw std::invalid_argument("grid of " + std::to_string(L.dims[0]) + " x " + std::to_string(L.dims[1]) +
                                " x " + std::to_string(L.dims[2]) + " nodes exceeds max_nodes=" +
                                std::to_string(max_nodes) + "; use a larger spacing or smaller bounds");
  py::array_t<float> values({L.dims[2], L.dims[1], L.dims[0]});
  float* out = values.mutable_data();
  const double* V = vertices.data();
  const int32_t* F = faces.data();
  const int64_t nv = vertices.shape(0), nf = faces.shape(0);
  body::SdfBuildStats st;
  {
    py::gil_scoped_release nogil;
    st = body::sdf_build(V, nv, F, nf, L, p, out);
  }
  return py::make_tuple(values, build_info(L, st, spacing, device));
}

// A view of a (nz, ny, nx) grid given as dims (nx, ny, nz) and origin, checked.
SdfGridView sample_grid(const F32& values, const py::object& dims_obj, const py::object& origin_obj,
                        double spacing) {
  auto dims = py::cast<std::vector<int64_t>>(dims_obj);
  auto origin = py::cast<std::vector<double>>(origin_obj);
  if (dims.size() != 3 || origin.size() != 3) throw std::invalid_argument("dims and origin must have 3 entries");
  if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2) throw std::invalid_argument("dims must be >= 2 on every axis");
  if (values.size() != dims[0] * dims[1] * dims[2])
    throw std::invalid_argument("values has " + std::to_string(values.size()) + " entries, dims need " +
                                std::to_string(dims[0] * dims[1] * dims[2]));
  if (!(spacing > 0) || !std::isfinite(spacing)) throw std::invalid_argument("spacing must be positive");
  require_finite_rows(origin.data(), 1, 3, "origin");
  SdfGridView g;
  g.values = values.data();
  g.nx = int(dims[0]);
  g.ny = int(dims[1]);
  g.nz = int(dims[2]);
  for (int a = 0; a < 3; ++a) g.origin[a] = origin[a];
  g.spacing = spacing;
  return g;
}

auto sdf_sample_points(F32 values, py::object dims_obj, py::object origin_obj, double spacing, F64 points) {
  const SdfGridView g = sample_grid(values, dims_obj, origin_obj, spacing);
  need_n3(points, "points");
  const int64_t n = points.shape(0);
  require_finite_rows(points.data(), n, 3, "points");
  py::array_t<double> phi(n);
  py::array_t<double> grad({n, int64_t(3)});
  const double* P = points.data();
  double* ph = phi.mutable_data();
  double* gr = grad.mutable_data();
  {
    py::gil_scoped_release nogil;
#pragma omp parallel for schedule(static) if (n > 20000)
    for (int64_t q = 0; q < n; ++q) {
      const SdfSample s = sdf_sample(g, make_vec3(P[3 * q], P[3 * q + 1], P[3 * q + 2]));
      ph[q] = s.phi;
      gr[3 * q] = s.grad.x;
      gr[3 * q + 1] = s.grad.y;
      gr[3 * q + 2] = s.grad.z;
    }
  }
  require_finite_samples(ph, gr, n);
  return py::make_tuple(phi, grad);
}

}  // namespace

// Binds the body functions: SDF layout, build and sampling.
void bind_body(py::module_& m) {
  m.def("sdf_layout", &sdf_layout, py::arg("vertices"), py::arg("spacing"), py::arg("padding"),
        py::arg("bounds") = py::none(), "Grid origin and dims (nx, ny, nz) that sdf_build would use.");
  m.def("sdf_build", &sdf_build, py::arg("vertices"), py::arg("faces"), py::arg("spacing") = 0.0025,
        py::arg("padding") = 0.05, py::arg("bounds") = py::none(), py::arg("band") = 1.5, py::arg("rounds") = 1,
        py::arg("threads") = 0, py::arg("max_nodes") = int64_t(400000000), py::arg("device") = "cpu",
        "Signed distance field of a triangle mesh on a regular grid (negative inside). Returns (values "
        "float32 (nz, ny, nx), info dict with origin, dims, spacing, device, timings and counters). device "
        "\"cuda\": exact nearest-triangle distances on the GPU (band and rounds unused), the sign on the CPU. "
        "Releases the GIL.");
  m.def("sdf_sample_points", &sdf_sample_points, py::arg("values"), py::arg("dims"), py::arg("origin"),
        py::arg("spacing"), py::arg("points"),
        "Trilinear phi (n,) and gradient (n, 3) at points (n, 3), via the simulator's sdf_sample.");
}

}  // namespace seamfit::bindings
