// The fitting costs of Section 6 on the CPU: distance (Eq. 11), smoothness (Eq. 12-13),
// stretching (Eq. 14) and positional (Eq. 16). Per-element math lives in
// opt/costs/*.hpp (shared with the CUDA path); this class owns the constant data
// derived from the base garment and pattern, runs the element loops with OpenMP and
// gathers gradients per vertex. A term whose strength is zero is never evaluated and
// needs none of its inputs.
#pragma once
#include <array>
#include <vector>

#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"
#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

enum CostTerm { kDistance = 0, kSmoothness = 1, kStretching = 2, kPositional = 3, kNumCostTerms = 4 };

struct CostStrengths {
  double dis = 0, smo = 0, str = 0, pos = 0;
};

// Read-only view of a CostSet's constant data, for a backend that mirrors it (the
// CUDA cost set copies it to the device).
struct CostSetView {
  int n = 0, n_edges = 0, n_hinges = 0;
  const int* edges = nullptr;            // 2 per edge
  const double* rbar = nullptr;          // per edge
  const int* hinges = nullptr;           // 4 per hinge
  const double* hinge_w = nullptr;       // 4 per hinge
  const double *cbar = nullptr, *sbar = nullptr;   // per hinge
  const int *edge_offsets = nullptr, *edge_slots = nullptr;    // gather: n + 1, 2E
  const int *hinge_offsets = nullptr, *hinge_slots = nullptr;  // gather: n + 1, 4H
  bool has_sdf = false, has_pos = false;
  SdfGridView sdf;                       // host memory
  const double* phibar = nullptr;        // n (with the field)
  const Vec3* xtilde = nullptr;          // n (positional)
  const double* u = nullptr;             // n (positional)
};

class CostSet {
 public:
  // pbar: (n, 2) base pattern in metres; xbar: (n, 3) base garment on the base body.
  CostSet(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar, const Vec3* xbar);

  void set_strengths(const CostStrengths& s) { strengths_ = s; }
  const CostStrengths& strengths() const { return strengths_; }
  // Target body SDF (non-owning view: the caller keeps the values alive) and the base
  // garment's distances phibar(xbar_i) to the base body.
  void set_distance(const SdfGridView& sdf, const double* phibar);
  // Transferred garment xtilde (Eq. 15) and per-vertex weights u_i.
  void set_positional(const Vec3* xtilde, const double* u);

  // Total value; per-term values into terms; gradients (n, 3) and (n, 2) overwritten.
  double evaluate(const Vec3* x, const Vec2* p, Vec3* grad_x, Vec2* grad_p,
                  std::array<double, kNumCostTerms>* terms);

  int n_vertices() const { return n_; }
  const std::vector<Edge>& edges() const { return edges_; }
  const std::vector<Hinge>& hinges() const { return hinges_; }
  const std::vector<std::array<double, 4>>& hinge_weights() const { return hinge_w_; }
  const std::vector<double>& stretch_ratio_bar() const { return rbar_; }
  // How many times each term has been evaluated (zero-strength terms stay at zero).
  const std::array<long long, kNumCostTerms>& evaluations() const { return evals_; }
  // Counted by a backend that evaluates this set elsewhere.
  void count_evaluation(CostTerm t) { ++evals_[t]; }
  CostSetView view() const;

 private:
  int n_;
  CostStrengths strengths_;
  std::vector<Edge> edges_;
  std::vector<double> rbar_;
  std::vector<Hinge> hinges_;
  std::vector<std::array<double, 4>> hinge_w_;
  std::vector<double> cbar_, sbar_;
  Gather edge_gather_, hinge_gather_;
  bool has_sdf_ = false, has_pos_ = false;
  SdfGridView sdf_;
  std::vector<double> phibar_, u_;
  std::vector<Vec3> xtilde_;
  std::array<long long, kNumCostTerms> evals_{};
  // Scratch: per-element values and gradient slots.
  std::vector<double> val_;
  std::vector<Vec3> slot_x_;
  std::vector<Vec2> slot_p_;
};

}  // namespace seamfit::opt
