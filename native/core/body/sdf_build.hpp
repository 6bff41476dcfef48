// Building a signed distance field (SdfGridView layout) from a triangle mesh.
//
//   1. Narrow band: exact point-triangle distances at every node within `band`
//      cells of each triangle's bounding box (each node keeps its closest triangle).
//   2. Propagation: closest-triangle propagation by plane sweeps (up and down in
//      z; within each plane a 2-D row sweep): a node tries the closest triangle of
//      the neighbour it is swept from and keeps it when nearer. Distances stay
//      exact point-triangle distances; only the choice of triangle is propagated.
//      When world bounds cut the mesh, the grid's border nodes are first seeded with
//      exact nearest-triangle queries (BVH), so triangles outside the box still count.
//   3. Sign: exact winding numbers, line by line along x, from signed ray crossings
//      (a consistent tie rule counts a ray through an edge or vertex exactly once).
//      An open mesh is closed by fan caps over its boundary loops; its generalized
//      winding number is then w = w(mesh + caps) - w(caps), where w(caps) is a sum of
//      solid angles evaluated only near the caps (elsewhere it is provably < 0.4 and
//      cannot change the inside test w > 1/2).
// All phases are parallel with OpenMP and need no Python, and the result is the
// same bits for any thread count (no phase depends on thread timing).
//
// On a GPU (params.gpu), phases 1 and 2 are replaced by the exact nearest-triangle
// distance of every node (a BVH query per node, native/core/body/sdf_gpu.cu); phase 3 is
// the same. Those values are exact everywhere, so they can be below the CPU's
// propagated ones (never above).
#pragma once
#include <cstdint>
#include <string>

namespace seamfit::body {

struct TriPre;
struct BvhNode;

// What the GPU distance pass needs: triangles (grid-centred frame), the BVH over
// them and the grid in the same frame.
struct SdfGpuInput {
  const TriPre* tris = nullptr;
  int64_t n_tris = 0;
  const BvhNode* nodes = nullptr;
  int64_t n_nodes = 0;
  const int32_t* order = nullptr;  // BVH leaf slots -> triangle indices (n_tris)
  double origin[3] = {0, 0, 0};
  double spacing = 0;
  int64_t dims[3] = {0, 0, 0};
};
// Fills out[nodes] with unsigned distances float(sqrt(d2)). The core does not link
// CUDA: a build with the CUDA backend passes its implementation in the params.
using SdfGpuDistancesFn = void (*)(const SdfGpuInput& in, float* out);

struct SdfBuildParams {
  double spacing = 0.0025;   // node spacing h (metres)
  double padding = 0.05;     // margin around the mesh's bounding box (metres)
  bool has_bounds = false;   // when set, the grid covers exactly [bounds_lo, bounds_hi]
  double bounds_lo[3] = {0, 0, 0};
  double bounds_hi[3] = {0, 0, 0};
  double band = 1.5;         // half-width of the exact band, in cells
  int rounds = 1;            // propagation rounds (one upward and one downward pass each)
  int threads = 0;           // 0: OpenMP default
  bool gpu = false;          // exact distances on a GPU through gpu_distances (band and rounds unused)
  SdfGpuDistancesFn gpu_distances = nullptr;
};

struct SdfLayout {
  double origin[3] = {0, 0, 0};
  int64_t dims[3] = {0, 0, 0};
  int64_t nodes() const { return dims[0] * dims[1] * dims[2]; }
};

struct SdfBuildStats {
  double seconds_total = 0, seconds_band = 0, seconds_seed = 0, seconds_propagate = 0, seconds_sign = 0;
  double seconds_gpu = 0;             // GPU build: BVH, upload, distances, download
  int64_t band_evaluations = 0;       // point-triangle distances in the band
  int64_t propagate_evaluations = 0;  // point-triangle distances during propagation
  int64_t seeded_nodes = 0;           // border nodes seeded by exact queries (bounds mode)
  int64_t cap_winding_nodes = 0;      // nodes whose sign needed cap solid angles (open meshes)
  int64_t boundary_edges = 0;         // net (oriented) boundary edges of the mesh
  int64_t caps = 0;                   // boundary components closed by a fan cap
  int64_t inside_nodes = 0;
  int threads = 0;
};

// Grid covering the mesh plus padding (centred on the mesh), or exactly the bounds.
// Throws std::invalid_argument for a bad spacing/padding/bounds or an empty mesh.
SdfLayout sdf_layout(const double* vertices, int64_t n_vertices, const SdfBuildParams& params);

// Fills out[nodes] (index i + nx*(j + ny*k)) with signed distances: negative inside.
// vertices: n_vertices x 3 doubles; faces: n_faces x 3 indices. Throws
// std::invalid_argument naming the face or vertex for out-of-range indices or
// non-finite coordinates, or for params.gpu without gpu_distances.
SdfBuildStats sdf_build(const double* vertices, int64_t n_vertices, const int32_t* faces, int64_t n_faces,
                        const SdfLayout& layout, const SdfBuildParams& params, float* out);

}  // namespace seamfit::body
