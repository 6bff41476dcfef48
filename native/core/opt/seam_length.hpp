// R^seam summed over the matched segments of every stitch, over theta (all seam
// vertices are boundary vertices, so the term needs no adjoint solve).
#pragma once
#include <Eigen/Sparse>
#include <array>
#include <vector>

#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

// Theta indices of one matched segment: side a (a0 -> a1) against side b (b0 -> b1).
using SeamSegment = std::array<int, 4>;

class SeamLength {
 public:
  // Segments whose base side b (or a) has zero length are dropped: no ratio to keep.
  SeamLength(const std::vector<Vec2>& theta_bar, const std::vector<SeamSegment>& segments);

  void set_strength(double delta_seam);
  double delta_seam() const { return delta_; }

  // Value; gradient (n_theta, 2) overwritten. Counts one evaluation.
  double evaluate(const Vec2* theta, Vec2* grad) const;
  // Per segment r (metres), the residual before squaring.
  std::vector<double> residuals(const Vec2* theta) const;
  // delta_seam sum J^T J with J at theta (Gauss-Newton; constant if theta = theta_bar).
  Eigen::SparseMatrix<double> gauss_newton(const Vec2* theta) const;

  int n_theta() const { return n_theta_; }
  const std::vector<SeamSegment>& segments() const { return seg_; }
  const std::vector<double>& ratios() const { return rho_; }
  long evaluations() const { return evaluations_; }
  // An evaluation made elsewhere (the GPU copy) on this term's data.
  void count_evaluation() const { ++evaluations_; }
  // theta entry -> its segment slots (4 e + c).
  const Gather& segment_gather() const { return gather_; }

 private:
  int n_theta_;
  std::vector<SeamSegment> seg_;
  std::vector<double> rho_;
  Gather gather_;
  double delta_ = 0;
  mutable long evaluations_ = 0;
};

}  // namespace seamfit::opt
