#include "opt/parametrization.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace seamfit::opt {

using SpMat = Eigen::SparseMatrix<double>;
using Triplet = Eigen::Triplet<double>;

Parametrization::Parametrization(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar,
                                 const unsigned char* is_boundary)
    : n_(n_vertices), pbar_(pbar, pbar + n_vertices) {
  std::vector<int> slot(n_, -1);
  for (int v = 0; v < n_; ++v) {
    if (is_boundary[v]) { slot[v] = int(boundary_.size()); boundary_.push_back(v); }
    else { slot[v] = int(interior_.size()); interior_.push_back(v); }
  }
  std::vector<char> used(n_, 0);
  std::vector<Triplet> trip;
  trip.reserve(tris.size() * 12);
  for (const Tri& t : tris) {
    for (int a = 0; a < 3; ++a) {
      if (t[a] < 0 || t[a] >= n_) throw std::invalid_argument("triangle index out of range");
      used[t[a]] = 1;
    }
    const Vec2 q[3] = {pbar[t[0]], pbar[t[1]], pbar[t[2]]};
    const Vec2 e1 = q[1] - q[0], e2 = q[2] - q[0];
    const double twice_area = std::fabs(e1.x * e2.y - e1.y * e2.x);
    if (!(twice_area > 0)) throw std::invalid_argument("degenerate triangle in the base pattern");
    for (int a = 0; a < 3; ++a) {
      // Half the cotangent of the angle at vertex a weighs the opposite edge (b, c).
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      const Vec2 u = q[b] - q[a], v = q[c] - q[a];
      const double w = 0.5 * dot(u, v) / twice_area;
      trip.emplace_back(t[b], t[c], -w);
      trip.emplace_back(t[c], t[b], -w);
      trip.emplace_back(t[b], t[b], w);
      trip.emplace_back(t[c], t[c], w);
    }
  }
  for (int v = 0; v < n_; ++v)
    if (!used[v]) throw std::invalid_argument("pattern vertex " + std::to_string(v) + " belongs to no triangle");
  L_.resize(n_, n_);
  L_.setFromTriplets(trip.begin(), trip.end());

  // Split the interior rows into the interior-interior and interior-boundary blocks.
  std::vector<Triplet> ti, tb;
  for (int c = 0; c < L_.outerSize(); ++c)
    for (SpMat::InnerIterator it(L_, c); it; ++it) {
      const int r = int(it.row()), col = int(it.col());
      if (is_boundary[r]) continue;
      if (is_boundary[col]) tb.emplace_back(slot[r], slot[col], it.value());
      else ti.emplace_back(slot[r], slot[col], it.value());
    }
  LI_.resize(int(interior_.size()), int(interior_.size()));
  LI_.setFromTriplets(ti.begin(), ti.end());
  LB_.resize(int(interior_.size()), int(boundary_.size()));
  LB_.setFromTriplets(tb.begin(), tb.end());
  if (!interior_.empty()) {
    chol_.compute(LI_);
    if (chol_.info() != Eigen::Success)
      throw std::invalid_argument("interior Laplacian is not positive definite: some interior vertices are "
                                  "not connected to a panel boundary");
  }
}

void Parametrization::pattern(const Vec2* theta, Vec2* p) const {
  const int nb = n_boundary(), ni = int(interior_.size());
  Eigen::MatrixX2d dB(nb, 2);
  for (int b = 0; b < nb; ++b) {
    const Vec2 d = theta[b] - pbar_[boundary_[b]];
    dB(b, 0) = d.x;
    dB(b, 1) = d.y;
    p[boundary_[b]] = theta[b];
  }
  if (ni == 0) return;
  const Eigen::MatrixX2d rhs = LB_ * dB;
  const Eigen::MatrixX2d dI = chol_.solve(rhs);
  for (int i = 0; i < ni; ++i) {
    const int v = interior_[i];
    p[v] = pbar_[v] - make_vec2(dI(i, 0), dI(i, 1));
  }
}

void Parametrization::adjoint(const Vec2* g, Vec2* g_theta) const {
  const int nb = n_boundary(), ni = int(interior_.size());
  for (int b = 0; b < nb; ++b) g_theta[b] = g[boundary_[b]];
  if (ni == 0) return;
  // dp^I/dtheta = -(L^I)^-1 L^B, so its transpose applied to g^I is -L^B^T (L^I)^-1 g^I
  // (L^I symmetric).
  Eigen::MatrixX2d gI(ni, 2);
  for (int i = 0; i < ni; ++i) {
    gI(i, 0) = g[interior_[i]].x;
    gI(i, 1) = g[interior_[i]].y;
  }
  const Eigen::MatrixX2d y = chol_.solve(gI);
  const Eigen::MatrixX2d back = LB_.transpose() * y;
  for (int b = 0; b < nb; ++b) g_theta[b] += make_vec2(-back(b, 0), -back(b, 1));
}

}  // namespace seamfit::opt
