// The fitting costs of Section 6 (Eq. 11-16) on the CPU: every term registered in
// opt/cost_terms.hpp. Per-element math lives in opt/costs/*.hpp (shared with the CUDA
// path); this class owns the elements and constants derived from the base garment and
// pattern, runs the element loops with OpenMP and gathers gradients per vertex. A term
// whose strength is zero is never evaluated and needs none of its inputs.
#pragma once
#include <array>
#include <vector>

#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"
#include "opt/cost_terms.hpp"
#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

// Per registered term, in registry order.
using CostStrengths = std::array<double, kNumCostTerms>;
using CostValues = std::array<double, kNumCostTerms>;

// The elements of one kind: count x arity vertex ids and their vertex gather table (the
// vertices have neither: element i is vertex i).
struct CostElements {
  int count = 0, arity = 1;
  std::vector<int> ids;
  Gather gather;
};

// Read-only view of a CostSet's constant data, for a backend that mirrors it (the
// CUDA cost set copies it to the device).
struct CostSetView {
  int n = 0;
  struct ElementsView {
    int count = 0, arity = 1;
    const int* ids = nullptr;                              // count x arity (not for vertices)
    const int *offsets = nullptr, *slots = nullptr;        // gather: n + 1, count x arity
  } elements[kNumElementKinds];
  const double* constants[kNumCostTerms] = {};             // count x the term's width
  bool ready[kNumCostTerms] = {};                          // constants present
  bool has_sdf = false;
  SdfGridView sdf;                                         // host memory
};

// Throws std::logic_error naming the first term with a strength whose inputs are missing
// (ready: its constants are present; has_sdf: the target SDF is).
void check_cost_inputs(const CostStrengths& strengths, const bool* ready, bool has_sdf);

class CostSet {
 public:
  // pbar: (n, 2) base pattern in metres; xbar: (n, 3) base garment on the base body.
  CostSet(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar, const Vec3* xbar);

  void set_strengths(const CostStrengths& s) { strengths_ = s; }
  const CostStrengths& strengths() const { return strengths_; }
  // Target body SDF (non-owning view: the caller keeps the values alive), for the terms
  // with kField.
  void set_target_sdf(const SdfGridView& sdf);
  // The constants of a term that takes them from the caller (its kInput): its element
  // count x its width doubles, copied.
  void set_inputs(CostTerm t, const double* values);

  // Total value; per-term values into terms; gradients (n, 3) and (n, 2) overwritten.
  double evaluate(const Vec3* x, const Vec2* p, Vec3* grad_x, Vec2* grad_p, CostValues* terms);
  // Throws std::logic_error when a term with a strength lacks its inputs.
  void check_inputs() const { check_cost_inputs(strengths_, ready_.data(), has_sdf_); }

  int n_vertices() const { return n_; }
  const CostElements& elements(Elements kind) const { return elements_[kind]; }
  const CostElements& elements(CostTerm t) const;
  const std::vector<double>& constants(CostTerm t) const { return constants_[t]; }
  int width(CostTerm t) const;
  // How many times each term has been evaluated (zero-strength terms stay at zero).
  const std::array<long long, kNumCostTerms>& evaluations() const { return evals_; }
  // Counted by a backend that evaluates this set elsewhere.
  void count_evaluation(CostTerm t) { ++evals_[t]; }
  CostSetView view() const;

 private:
  template <class T>
  double accumulate(CostTerm t, const CostInputs& in, double k, Vec3* gx, Vec2* gp);

  int n_;
  CostStrengths strengths_{};
  std::array<CostElements, kNumElementKinds> elements_;
  std::array<std::vector<double>, kNumCostTerms> constants_;
  std::array<bool, kNumCostTerms> ready_{};
  bool has_sdf_ = false;
  SdfGridView sdf_;
  std::array<long long, kNumCostTerms> evals_{};
  // Scratch: per-element values and gradient slots.
  std::vector<double> val_;
  std::vector<Vec3> slot_x_;
  std::vector<Vec2> slot_p_;
};

}  // namespace seamfit::opt
