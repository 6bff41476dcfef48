#include "opt/regularizer_set.hpp"

#include <algorithm>
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
  gather_.build(elem_.empty() ? nullptr : &elem_[0][0], int(elem_.size()), 3, nt);
}

void Regularizers::set_strengths(double delta_fix, double delta_cur) {
  if (delta_fix < 0 || delta_cur < 0) throw std::invalid_argument("regularizer strengths must be >= 0");
  if (delta_fix != fix_ || delta_cur != cur_) {
    factored_ = false;
    ++version_;
  }
  fix_ = delta_fix;
  cur_ = delta_cur;
}

double Regularizers::evaluate(const Vec2* theta, Vec2* grad, std::array<double, 2>* terms) const {
  // Elements, then a gather per theta entry: the steps the GPU kernels take (costs/regularizers.hpp).
  const int nt = n_theta();
  const bool cur_on = cur_ != 0;
  std::vector<Vec2> slot(cur_on ? 3 * elem_.size() : 0);
  double rfix = 0, rcur = 0;
  if (cur_on)
    for (size_t e = 0; e < elem_.size(); ++e)
      rcur += curve_element(theta, elem_[e].data(), z_[e], cur_ * w_[e], &slot[3 * e]);
  for (int b = 0; b < nt; ++b) {
    double vf;
    grad[b] = regularizer_gradient_at(b, theta, theta_bar_.data(), fix_, cur_on, gather_.offsets.data(),
                                      gather_.slots.data(), slot.data(), &vf);
    rfix += vf;
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
  ++version_;
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

void Regularizers::dense_inverse(double* out) {
  if (!factored_) factorize();
  const long n = 2L * n_theta();
  // Columns of P^-1 in blocks of unit vectors; the solves only read the factorization.
  constexpr long kBlock = 64;
  const long nblocks = (n + kBlock - 1) / kBlock;
#pragma omp parallel for schedule(dynamic)
  for (long blk = 0; blk < nblocks; ++blk) {
    const long c0 = blk * kBlock, nc = std::min(kBlock, n - c0);
    Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n, nc);
    for (long c = 0; c < nc; ++c) E(c0 + c, c) = 1.0;
    const Eigen::MatrixXd X = chol_.solve(E);
    // Column c of P^-1 into row c (equal for a symmetric P up to rounding).
    for (long c = 0; c < nc; ++c)
      for (long r = 0; r < n; ++r) out[(c0 + c) * n + r] = X(r, c);
  }
  // Exactly symmetric, as P is: the mean of the two triangles.
#pragma omp parallel for schedule(dynamic, 16)
  for (long r = 0; r < n; ++r)
    for (long c = r + 1; c < n; ++c) {
      const double m = 0.5 * (out[r * n + c] + out[c * n + r]);
      out[r * n + c] = m;
      out[c * n + r] = m;
    }
}

}  // namespace seamfit::opt
