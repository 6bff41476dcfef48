#include "opt/cost_set.hpp"

#include <algorithm>
#include <stdexcept>

#include "opt/costs/distance.hpp"
#include "opt/costs/gather.hpp"
#include "opt/costs/positional.hpp"
#include "opt/costs/smoothness.hpp"
#include "opt/costs/stretching.hpp"

namespace seamfit::opt {

CostSet::CostSet(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar, const Vec3* xbar)
    : n_(n_vertices) {
  for (const Tri& t : tris)
    for (int v : t)
      if (v < 0 || v >= n_) throw std::invalid_argument("triangle index out of range");
  edges_ = unique_edges(tris);
  rbar_.resize(edges_.size());
  for (size_t e = 0; e < edges_.size(); ++e) {
    const int i = edges_[e][0], j = edges_[e][1];
    const double lp = norm(pbar[i] - pbar[j]);
    if (!(lp > 0)) throw std::invalid_argument("zero-length edge in the base pattern");
    rbar_[e] = norm(xbar[i] - xbar[j]) / lp;
  }
  hinges_ = interior_hinges(tris);
  // Sliver hinges carry no smoothness cost (as they carry no bending in the simulator).
  hinges_.erase(std::remove_if(hinges_.begin(), hinges_.end(),
                               [&](const Hinge& h) { return !hinge_well_shaped(h, pbar); }),
                hinges_.end());
  hinge_w_.resize(hinges_.size());
  cbar_.resize(hinges_.size());
  sbar_.resize(hinges_.size());
  for (size_t h = 0; h < hinges_.size(); ++h) {
    hinge_w_[h] = hinge_kernel(hinges_[h], pbar);
    const Vec3 xb[4] = {xbar[hinges_[h][0]], xbar[hinges_[h][1]], xbar[hinges_[h][2]], xbar[hinges_[h][3]]};
    cbar_[h] = norm(hinge_apply(hinge_w_[h].data(), xb));
    sbar_[h] = hinge_side(hinge_w_[h].data(), xb);
  }
  edge_gather_.build(&edges_[0][0], int(edges_.size()), 2, n_);
  if (!hinges_.empty()) hinge_gather_.build(&hinges_[0][0], int(hinges_.size()), 4, n_);
  else hinge_gather_.build(nullptr, 0, 4, n_);
}

void CostSet::set_distance(const SdfGridView& sdf, const double* phibar) {
  if (!sdf.values || sdf.nx < 2 || sdf.ny < 2 || sdf.nz < 2 || !(sdf.spacing > 0))
    throw std::invalid_argument("invalid signed distance grid");
  sdf_ = sdf;
  phibar_.assign(phibar, phibar + n_);
  has_sdf_ = true;
}

void CostSet::set_positional(const Vec3* xtilde, const double* u) {
  xtilde_.assign(xtilde, xtilde + n_);
  u_.assign(u, u + n_);
  has_pos_ = true;
}

CostSetView CostSet::view() const {
  CostSetView v;
  v.n = n_;
  v.n_edges = int(edges_.size());
  v.n_hinges = int(hinges_.size());
  v.edges = edges_.empty() ? nullptr : &edges_[0][0];
  v.rbar = rbar_.data();
  v.hinges = hinges_.empty() ? nullptr : &hinges_[0][0];
  v.hinge_w = hinge_w_.empty() ? nullptr : hinge_w_[0].data();
  v.cbar = cbar_.data();
  v.sbar = sbar_.data();
  v.edge_offsets = edge_gather_.offsets.data();
  v.edge_slots = edge_gather_.slots.data();
  v.hinge_offsets = hinge_gather_.offsets.data();
  v.hinge_slots = hinge_gather_.slots.data();
  v.has_sdf = has_sdf_;
  v.has_pos = has_pos_;
  v.sdf = sdf_;
  v.phibar = phibar_.data();
  v.xtilde = xtilde_.data();
  v.u = u_.data();
  return v;
}

// Below this many elements a loop runs on one thread: spawning a team costs more than it
// saves, and far more when the cores are shared with other processes.
constexpr int kParallelMin = 20000;

static double serial_sum(const std::vector<double>& v, size_t n) {
  double s = 0;
  for (size_t i = 0; i < n; ++i) s += v[i];
  return s;
}

double CostSet::evaluate(const Vec3* x, const Vec2* p, Vec3* gx, Vec2* gp,
                         std::array<double, kNumCostTerms>* terms) {
  const int n = n_;
  std::array<double, kNumCostTerms> t{};
  for (int i = 0; i < n; ++i) gx[i] = make_vec3(0, 0, 0);
  for (int i = 0; i < n; ++i) gp[i] = make_vec2(0, 0);

  if (strengths_.dis != 0) {
    if (!has_sdf_) throw std::logic_error("distance cost has a strength but no target SDF");
    ++evals_[kDistance];
    val_.resize(n);
    const double k = strengths_.dis;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int i = 0; i < n; ++i) {
      Vec3 g;
      val_[i] = distance_cost(sdf_, x[i], phibar_[i], k, &g);
      gx[i] += g;
    }
    t[kDistance] = serial_sum(val_, n);
  }

  if (strengths_.pos != 0) {
    if (!has_pos_) throw std::logic_error("positional cost has a strength but no transferred garment");
    ++evals_[kPositional];
    val_.resize(n);
    const double k = strengths_.pos;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int i = 0; i < n; ++i) {
      Vec3 g;
      val_[i] = positional_cost(x[i], xtilde_[i], k * u_[i], &g);
      gx[i] += g;
    }
    t[kPositional] = serial_sum(val_, n);
  }

  if (strengths_.str != 0) {
    ++evals_[kStretching];
    const int ne = int(edges_.size());
    val_.resize(ne);
    slot_x_.resize(2 * size_t(ne));
    slot_p_.resize(2 * size_t(ne));
    const double k = strengths_.str;
#pragma omp parallel for schedule(static) if (ne >= kParallelMin)
    for (int e = 0; e < ne; ++e) {
      const int i = edges_[e][0], j = edges_[e][1];
      val_[e] = stretching_cost(x[i], x[j], p[i], p[j], rbar_[e], k, &slot_x_[2 * e], &slot_x_[2 * e + 1],
                                &slot_p_[2 * e], &slot_p_[2 * e + 1]);
    }
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int v = 0; v < n; ++v) {
      gather_add(v, edge_gather_.offsets.data(), edge_gather_.slots.data(), slot_x_.data(), gx[v]);
      gather_add(v, edge_gather_.offsets.data(), edge_gather_.slots.data(), slot_p_.data(), gp[v]);
    }
    t[kStretching] = serial_sum(val_, ne);
  }

  if (strengths_.smo != 0) {
    ++evals_[kSmoothness];
    const int nh = int(hinges_.size());
    val_.resize(nh);
    slot_x_.resize(4 * size_t(nh));
    const double k = strengths_.smo;
#pragma omp parallel for schedule(static) if (nh >= kParallelMin)
    for (int h = 0; h < nh; ++h) {
      const Hinge& hg = hinges_[h];
      const Vec3 xs[4] = {x[hg[0]], x[hg[1]], x[hg[2]], x[hg[3]]};
      val_[h] = smoothness_cost(xs, hinge_w_[h].data(), cbar_[h], sbar_[h], k, &slot_x_[4 * size_t(h)]);
    }
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int v = 0; v < n; ++v)
      gather_add(v, hinge_gather_.offsets.data(), hinge_gather_.slots.data(), slot_x_.data(), gx[v]);
    t[kSmoothness] = serial_sum(val_, nh);
  }

  if (terms) *terms = t;
  return t[kDistance] + t[kSmoothness] + t[kStretching] + t[kPositional];
}

}  // namespace seamfit::opt
