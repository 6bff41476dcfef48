// Pattern parametrization by boundary vertices (Section 5, Eq. 7-8).
//
// theta = the boundary vertices p^B of every panel; interior vertices follow
//   p^I = pbar^I - (L^I)^-1 L^B (p^B - pbar^B),
// i.e. the displacement p - pbar is discrete-harmonic in the interior. L is the
// cotangent Laplacian (linear FEM stiffness matrix) of the BASE pattern, assembled per
// triangle, so panels (which share no triangles) decouple:
//   L_uv = -1/2 (cot a_uv + cot b_uv)  for an edge u-v with opposite angles a, b,
//   L_uu = -sum_v L_uv.
// L is the same for the u and v coordinates. For any nodal vector f,
// f^T L f = sum_t area_t |grad f_t|^2 >= 0 exactly (flat rest shape), and it vanishes
// only when f is constant on each connected piece; fixing the boundary (f^B = 0) makes
// that constant zero, so L^I is symmetric positive definite whenever every interior
// vertex is connected to the boundary through nondegenerate triangles, even with
// obtuse triangles (negative edge weights). Because interior rows of L annihilate
// affine functions of the flat rest positions, an affine (in particular rigid or
// similarity) motion of the boundary moves the interior by the same map.
#pragma once
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <vector>

#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

class Parametrization {
 public:
  // is_boundary: per vertex, nonzero for a panel boundary vertex. theta lists the
  // boundary vertices in increasing vertex id. Throws std::invalid_argument when a
  // vertex has no triangle, a triangle is degenerate or L^I is not positive definite.
  Parametrization(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar, const unsigned char* is_boundary);

  int n_vertices() const { return n_; }
  int n_boundary() const { return int(boundary_.size()); }
  const std::vector<int>& boundary_ids() const { return boundary_; }
  const std::vector<int>& interior_ids() const { return interior_; }
  const std::vector<Vec2>& pbar() const { return pbar_; }

  // p(theta): theta (n_boundary, 2) -> p (n_vertices, 2).
  void pattern(const Vec2* theta, Vec2* p) const;
  // (dp/dtheta)^T g for g (n_vertices, 2) -> (n_boundary, 2).
  void adjoint(const Vec2* g, Vec2* g_theta) const;

  const Eigen::SparseMatrix<double>& laplacian() const { return L_; }

  // The interior update as dense blocks, one per panel (connected piece), for the
  // GPU (opt/pattern_gpu): panel k's interior moves by M_k (theta_k - theta_bar_k)
  // with M_k = -(L^I_k)^-1 L^B_k. L^I is constant (the base pattern's), so this is
  // computed once; the blocks hold sum_k n^I_k n^B_k doubles (harmonic_doubles()).
  struct HarmonicBlock {
    std::vector<int> rows;   // indices into interior_ids()
    std::vector<int> cols;   // indices into theta (boundary_ids())
    std::vector<double> M;   // rows.size() x cols.size(), row-major
  };
  size_t harmonic_doubles() const;
  std::vector<HarmonicBlock> harmonic_blocks() const;

 private:
  int n_;
  std::vector<Vec2> pbar_;
  std::vector<int> boundary_, interior_;
  std::vector<int> panel_;  // per vertex: its connected piece (panel)
  int n_panels_ = 0;
  Eigen::SparseMatrix<double> L_, LI_, LB_;
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> chol_;
};

}  // namespace seamfit::opt
