// Mesh connectivity the optimizer's costs run over: unique edges (stretching),
// interior hinges and their kernels (smoothness), and vertex gather tables that
// sum per-element gradient slots into per-vertex gradients without atomics, so
// results do not depend on the thread count.
#pragma once
#include <array>
#include <vector>

#include "opt/vec2.hpp"

namespace seamfit::opt {

using Tri = std::array<int, 3>;
using Edge = std::array<int, 2>;
// (i, j, k, l): shared edge i-j, k opposite in triangle (i, j, k), l in (j, i, l).
using Hinge = std::array<int, 4>;

// Undirected edges of the triangles, each once, sorted by (min, max).
std::vector<Edge> unique_edges(const std::vector<Tri>& tris);

// Edges shared by exactly two consistently oriented triangles. Throws
// std::invalid_argument when two triangles sharing an edge disagree in orientation.
std::vector<Hinge> interior_hinges(const std::vector<Tri>& tris);

// Sliver guard shared with the simulator's bending stencil: a triangle whose doubled
// area is below this fraction of its squared longest edge has unbounded cotangents.
constexpr double kHingeMinShape = 1e-6;
// True when both triangles of the hinge are well shaped in the rest positions.
bool hinge_well_shaped(const Hinge& h, const Vec2* rest);

// Kernel weights (w_i, w_j, w_k, w_l) of a hinge from flat rest positions (the base
// pattern), scaled by 1/|e|:
//   w_k = cot(a_i1) + cot(a_j1),  w_l = cot(a_i2) + cot(a_j2),
//   w_i = -(cot(a_j1) + cot(a_j2)),  w_j = -(cot(a_i1) + cot(a_i2)),   all / |e|
// where a_v1 (a_v2) is the interior angle at v in triangle 1 (2). Then
// sum_a w_a x_a = u_k + u_l with u_k, u_l the unit perpendiculars from the edge line
// to k and l, evaluated with rest-shape coefficients: zero for any affine image of the
// rest hinge, and of length 2 sin(theta/2) when the hinge is folded isometrically by
// the dihedral angle theta (Bergou et al. 2006, Garg et al. 2007).
std::array<double, 4> hinge_kernel(const Hinge& h, const Vec2* rest);

// Gather table: for vertex v, slots[offsets[v] .. offsets[v+1]) are the flat indices
// e * k + a of the element slots (element e, local vertex a) that touch v.
struct Gather {
  std::vector<int> offsets, slots;
  void build(const int* elem, int n_elem, int k, int n_vertices);
};

}  // namespace seamfit::opt
