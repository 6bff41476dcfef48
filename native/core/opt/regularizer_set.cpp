#include "opt/regularizer_set.hpp"

#include <stdexcept>

#include "opt/costs/regularizers.hpp"

namespace seamfit::opt {

Regularizers::Regularizers(const std::vector<Vec2>& theta_bar, const std::vector<std::vector<int>>& loops,
                           const std::vector<double>& weight)
    : theta_bar_(theta_bar) {
  const int nt = int(theta_bar_.size());
  if (int(weight.size()) != nt) throw std::invalid_argument("one curve weight per boundary vertex expected");
  for (const auto& loop : loops) {
    const int m = int(loop.size());
    if (m < 3) continue;  // no second difference on fewer than three vertices
    for (int a = 0; a < m; ++a) {
      const int j = loop[(a + m - 1) % m], i = loop[a], k = loop[(a + 1) % m];
      if (i < 0 || i >= nt) throw std::invalid_argument("boundary loop index out of range");
      elem_.push_back({j, i, k});
      z_.push_back(curve_frame(theta_bar_[j], theta_bar_[i], theta_bar_[k]));
      w_.push_back(weight[i]);
    }
  }
}

void Regularizers::set_strengths(double delta_fix, double delta_cur) {
  if (delta_fix < 0 || delta_cur < 0) throw std::invalid_argument("regularizer strengths must be >= 0");
  if (delta_fix != fix_ || delta_cur != cur_) factored_ = false;
  fix_ = delta_fix;
  cur_ = delta_cur;
}

double Regularizers::evaluate(const Vec2* theta, Vec2* grad, std::array<double, 2>* terms) const {
  const int nt = n_theta();
  for (int b = 0; b < nt; ++b) grad[b] = make_vec2(0, 0);
  double rfix = 0, rcur = 0;
  if (fix_ != 0)
    for (int b = 0; b < nt; ++b) {
      Vec2 g;
      rfix += fix_regularizer(theta[b], theta_bar_[b], fix_, &g);
      grad[b] += g;
    }
  if (cur_ != 0)
    for (size_t e = 0; e < elem_.size(); ++e) {
      const auto& el = elem_[e];
      Vec2 gj, gi, gk;
      rcur += curve_regularizer(theta[el[0]], theta[el[1]], theta[el[2]], z_[e], cur_ * w_[e], &gj, &gi, &gk);
      grad[el[0]] += gj;
      grad[el[1]] += gi;
      grad[el[2]] += gk;
    }
  if (terms) *terms = {rfix, rcur};
  return rfix + rcur;
}

Eigen::SparseMatrix<double> Regularizers::hessian() const {
  const int nt = n_theta();
  std::vector<Eigen::Triplet<double>> trip;
  for (int r = 0; r < 2 * nt; ++r) trip.emplace_back(r, r, fix_);
  if (cur_ != 0)
    for (size_t e = 0; e < elem_.size(); ++e) {
      // Blocks of A_e: I + Z (p_j), -2 I (p_i), I - Z (p_k), Z = [[zr, -zi], [zi, zr]].
      const double zr = z_[e].x, zi = z_[e].y;
      const double blk[3][2][2] = {{{1 + zr, -zi}, {zi, 1 + zr}}, {{-2, 0}, {0, -2}}, {{1 - zr, zi}, {-zi, 1 - zr}}};
      const double kw = cur_ * w_[e];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 2; ++c) {
              // (A_a^T A_b)_{rc} = sum_s A_a[s][r] A_b[s][c]
              const double v = blk[a][0][r] * blk[b][0][c] + blk[a][1][r] * blk[b][1][c];
              if (v != 0) trip.emplace_back(2 * elem_[e][a] + r, 2 * elem_[e][b] + c, kw * v);
            }
    }
  Eigen::SparseMatrix<double> H(2 * nt, 2 * nt);
  H.setFromTriplets(trip.begin(), trip.end());
  if (extra_.size() != 0) H += extra_;
  return H;
}

void Regularizers::set_extra_hessian(const Eigen::SparseMatrix<double>& H) {
  if (H.size() != 0 && (H.rows() != 2 * n_theta() || H.cols() != 2 * n_theta()))
    throw std::invalid_argument("extra preconditioner block must be (2 n_theta, 2 n_theta)");
  extra_ = H;
  factored_ = false;
}

void Regularizers::factorize() {
  if (!(fix_ > 0)) throw std::invalid_argument("the preconditioner needs delta_fix > 0 to be positive definite");
  chol_.compute(hessian());
  if (chol_.info() != Eigen::Success) throw std::runtime_error("preconditioner factorization failed");
  factored_ = true;
}

void Regularizers::apply_preconditioner(const Vec2* g, Vec2* out) {
  if (!factored_) factorize();
  const int nt = n_theta();
  Eigen::VectorXd v(2 * nt);
  for (int b = 0; b < nt; ++b) { v[2 * b] = g[b].x; v[2 * b + 1] = g[b].y; }
  const Eigen::VectorXd s = chol_.solve(v);
  for (int b = 0; b < nt; ++b) out[b] = make_vec2(s[2 * b], s[2 * b + 1]);
}

}  // namespace seamfit::opt
