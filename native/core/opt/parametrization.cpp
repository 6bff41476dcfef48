#include "opt/parametrization.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
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

  // Panels: the connected pieces of the triangle graph (union-find over triangle vertices).
  std::vector<int> root(n_);
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (const Tri& t : tris)
    for (int a = 1; a < 3; ++a) root[find(t[a])] = find(t[0]);
  panel_.assign(n_, -1);
  std::vector<int> id_of_root(n_, -1);
  for (int v = 0; v < n_; ++v) {
    const int r = find(v);
    if (id_of_root[r] < 0) id_of_root[r] = n_panels_++;
    panel_[v] = id_of_root[r];
  }

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

size_t Parametrization::harmonic_doubles() const {
  std::vector<size_t> ni(n_panels_, 0), nb(n_panels_, 0);
  for (int v : interior_) ++ni[panel_[v]];
  for (int v : boundary_) ++nb[panel_[v]];
  size_t total = 0;
  for (int k = 0; k < n_panels_; ++k) total += ni[k] * nb[k];
  return total;
}

std::vector<Parametrization::HarmonicBlock> Parametrization::harmonic_blocks() const {
  std::vector<HarmonicBlock> blocks(n_panels_);
  for (int i = 0; i < int(interior_.size()); ++i) blocks[panel_[interior_[i]]].rows.push_back(i);
  for (int b = 0; b < n_boundary(); ++b) blocks[panel_[boundary_[b]]].cols.push_back(b);
  for (HarmonicBlock& B : blocks) {
    const int ni = int(B.rows.size()), nb = int(B.cols.size());
    if (ni == 0 || nb == 0) continue;
    // This panel's L^I_k and L^B_k (panels share no entries of L).
    std::vector<int> local_row(interior_.size(), -1), local_col(boundary_.size(), -1);
    for (int r = 0; r < ni; ++r) local_row[B.rows[r]] = r;
    for (int c = 0; c < nb; ++c) local_col[B.cols[c]] = c;
    std::vector<Triplet> ti, tb;
    for (int c = 0; c < LI_.outerSize(); ++c)
      for (SpMat::InnerIterator it(LI_, c); it; ++it)
        if (local_row[it.row()] >= 0 && local_row[c] >= 0) ti.emplace_back(local_row[it.row()], local_row[c], it.value());
    for (int c = 0; c < LB_.outerSize(); ++c)
      for (SpMat::InnerIterator it(LB_, c); it; ++it)
        if (local_row[it.row()] >= 0 && local_col[c] >= 0) tb.emplace_back(local_row[it.row()], local_col[c], it.value());
    SpMat LIk(ni, ni), LBk(ni, nb);
    LIk.setFromTriplets(ti.begin(), ti.end());
    LBk.setFromTriplets(tb.begin(), tb.end());
    Eigen::SimplicialLLT<SpMat> chol(LIk);
    if (chol.info() != Eigen::Success) throw std::invalid_argument("interior Laplacian of a panel is not positive definite");
    B.M.assign(size_t(ni) * nb, 0.0);
    // One column of M_k per boundary entry; the columns are independent solves.
#pragma omp parallel for schedule(dynamic, 8)
    for (int c = 0; c < nb; ++c) {
      const Eigen::VectorXd rhs = Eigen::VectorXd(LBk.col(c));
      const Eigen::VectorXd col = chol.solve(rhs);
      for (int r = 0; r < ni; ++r) B.M[size_t(r) * nb + c] = -col[r];
    }
  }
  return blocks;
}

}  // namespace seamfit::opt
