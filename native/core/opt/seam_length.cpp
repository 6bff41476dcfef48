#include "opt/seam_length.hpp"

#include <stdexcept>

#include "opt/costs/gather.hpp"
#include "opt/costs/seam_length.hpp"

namespace seamfit::opt {

SeamLength::SeamLength(const std::vector<Vec2>& theta_bar, const std::vector<SeamSegment>& segments)
    : n_theta_(int(theta_bar.size())) {
  for (const auto& s : segments) {
    for (int c = 0; c < 4; ++c)
      if (s[c] < 0 || s[c] >= n_theta_) throw std::invalid_argument("seam segment index out of range");
    const double la = norm(theta_bar[s[1]] - theta_bar[s[0]]);
    const double lb = norm(theta_bar[s[3]] - theta_bar[s[2]]);
    if (!(la > 0 && lb > 0)) continue;
    seg_.push_back(s);
    rho_.push_back(la / lb);
  }
  gather_.build(seg_.empty() ? nullptr : &seg_[0][0], int(seg_.size()), 4, n_theta_);
}

void SeamLength::set_strength(double delta_seam) {
  if (!(delta_seam >= 0)) throw std::invalid_argument("seam strength must be >= 0");
  delta_ = delta_seam;
}

double SeamLength::evaluate(const Vec2* theta, Vec2* grad) const {
  // Segments, then a gather per theta entry: the steps the GPU kernels take.
  ++evaluations_;
  std::vector<Vec2> slot(4 * seg_.size());
  double v = 0;
  for (size_t e = 0; e < seg_.size(); ++e) v += seam_element(theta, seg_[e].data(), rho_[e], delta_, &slot[4 * e]);
  for (int b = 0; b < n_theta_; ++b) {
    grad[b] = make_vec2(0, 0);
    gather_add(b, gather_.offsets.data(), gather_.slots.data(), slot.data(), grad[b]);
  }
  return v;
}

std::vector<double> SeamLength::residuals(const Vec2* theta) const {
  std::vector<double> r(seg_.size());
  for (size_t e = 0; e < seg_.size(); ++e) {
    const auto& s = seg_[e];
    r[e] = seam_residual(theta[s[0]], theta[s[1]], theta[s[2]], theta[s[3]], rho_[e]);
  }
  return r;
}

Eigen::SparseMatrix<double> SeamLength::gauss_newton(const Vec2* theta) const {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(seg_.size() * 64);
  for (size_t e = 0; e < seg_.size(); ++e) {
    const auto& s = seg_[e];
    Vec2 J[4];
    seam_jacobian(theta[s[0]], theta[s[1]], theta[s[2]], theta[s[3]], rho_[e], J);
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const double ja[2] = {J[a].x, J[a].y}, jb[2] = {J[b].x, J[b].y};
        for (int r = 0; r < 2; ++r)
          for (int c = 0; c < 2; ++c) {
            const double v = delta_ * ja[r] * jb[c];
            if (v != 0) trip.emplace_back(2 * s[a] + r, 2 * s[b] + c, v);
          }
      }
  }
  Eigen::SparseMatrix<double> H(2 * n_theta_, 2 * n_theta_);
  H.setFromTriplets(trip.begin(), trip.end());
  return H;
}

}  // namespace seamfit::opt
