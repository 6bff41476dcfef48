#include "sim/tangent_solver.hpp"

#include <algorithm>
#include <cmath>

namespace seamfit::sim {

namespace {
// A pivot smaller than this fraction of the largest counts as zero: the
// solve would amplify rounding by more than 1/kPivotFloor.
constexpr double kPivotFloor = 1e-13;
}  // namespace

bool TangentSolver::factorize(const double* x, bool psd, double shift) {
  ready_ = false;
  Hs_ = sim_.hessian(x, psd);
  const Eigen::Index n = Hs_.rows();
  double mean_diag = 0;
  for (Eigen::Index c = 0; c < n; ++c) mean_diag += std::abs(Hs_.coeff(c, c));
  mean_diag = n > 0 ? mean_diag / double(n) : 1.0;
  if (!std::isfinite(mean_diag)) return false;
  if (shift > 0) {
    for (Eigen::Index c = 0; c < n; ++c) Hs_.coeffRef(c, c) += shift * mean_diag;
  }
  if (!analysed_) {
    ldlt_.analyzePattern(Hs_);
    analysed_ = true;
  }
  ldlt_.factorize(Hs_);
  ++factorizations_;
  if (ldlt_.info() != Eigen::Success) return false;
  const auto& D = ldlt_.vectorD();
  const double dmax = D.cwiseAbs().maxCoeff();
  if (!(dmax > 0) || !std::isfinite(dmax) || !(D.cwiseAbs().minCoeff() > kPivotFloor * dmax)) return false;
  ready_ = true;
  return true;
}

void TangentSolver::solve(const double* g, double* out) const {
  const Eigen::Index n = Hs_.rows();
  Eigen::Map<const Eigen::VectorXd> G(g, n);
  Eigen::Map<Eigen::VectorXd> O(out, n);
  O = ldlt_.solve(G);
}

}  // namespace seamfit::sim
