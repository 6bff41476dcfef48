#include "sim/simulator.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "sim/dfdp.hpp"
#include "sim/jacobi_step.hpp"
#include "sim/rest_state.hpp"
#include "sim/terms/barrier.hpp"
#include "sim/terms/bending.hpp"
#include "sim/terms/mass.hpp"
#include "sim/terms/sdf_smooth.hpp"
#include "sim/terms/spring.hpp"

namespace seamfit::sim {

namespace {

inline Vec3 vget(const double* x, int i) { return {x[3 * i], x[3 * i + 1], x[3 * i + 2]}; }
inline void vset(double* x, int i, Vec3 v) {
  x[3 * i] = v.x;
  x[3 * i + 1] = v.y;
  x[3 * i + 2] = v.z;
}

// Counting-sort construction of a CSR list from (vertex, payload) pairs.
void build_csr(int n, const std::vector<int32_t>& keys, std::vector<int32_t>& ptr, std::vector<int32_t>& order) {
  ptr.assign(n + 1, 0);
  for (int32_t k : keys) ptr[k + 1]++;
  for (int i = 0; i < n; ++i) ptr[i + 1] += ptr[i];
  order.assign(keys.size(), 0);
  std::vector<int32_t> fill(ptr.begin(), ptr.end() - 1);
  for (size_t e = 0; e < keys.size(); ++e) order[fill[keys[e]]++] = int32_t(e);
}

}  // namespace

Simulator::Simulator(int n, const double* p, int n_tris, const int32_t* tris, int n_sew, const int32_t* sew,
                     const SimParams& params)
    : n_(n), params_(params) {
  if (n <= 0) throw SimError("simulator: the mesh has no vertices");
  set_threads(0);
  if (n_tris <= 0) throw SimError("simulator: the mesh has no triangles");
  for (int i = 0; i < 2 * n; ++i)
    if (!std::isfinite(p[i])) throw SimError("simulator: pattern coordinate " + std::to_string(i / 2) + " is not finite");
  p_.assign(p, p + 2 * n);
  build_topology(n_tris, tris, n_sew, sew);
  shirring_.assign(n_springs(), 1.0);
  stick_k_.assign(n_, 0.0);
  stick_t_.assign(3 * size_t(n_), 0.0);
  // Floors for degenerate input (zero-length edges, zero-area triangles), fixed
  // at construction so they do not move with p.
  double sumL = 0;
  for (int e = 0; e < n_springs(); ++e) {
    const int i = spring_v_[2 * e], j = spring_v_[2 * e + 1];
    sumL += std::hypot(p_[2 * i] - p_[2 * j], p_[2 * i + 1] - p_[2 * j + 1]);
  }
  L_floor_ = std::max(1e-3 * sumL / std::max(1, n_springs()), 1e-9);
  update_rest_state();
  double summ = 0;
  for (double m : mass_) summ += m;
  m_floor_ = 1e-3 * summ / n_;
  if (!(m_floor_ > 0)) m_floor_ = 1e-12;
  update_barrier_weights();
  build_hessian_pattern();
}

void Simulator::build_topology(int n_tris, const int32_t* tris, int n_sew, const int32_t* sew) {
  tris_.assign(tris, tris + 3 * size_t(n_tris));
  for (int t = 0; t < n_tris; ++t) {
    const int a = tris_[3 * t], b = tris_[3 * t + 1], c = tris_[3 * t + 2];
    if (a < 0 || b < 0 || c < 0 || a >= n_ || b >= n_ || c >= n_)
      throw SimError("simulator: triangle " + std::to_string(t) + " has a vertex index out of range");
    if (a == b || b == c || a == c)
      throw SimError("simulator: triangle " + std::to_string(t) + " repeats a vertex");
  }
  // Edges: (key, triangle, opposite vertex), grouped by sorting.
  struct Rec { int64_t key; int32_t tri, opp; };
  std::vector<Rec> rec;
  rec.reserve(3 * size_t(n_tris));
  for (int t = 0; t < n_tris; ++t)
    for (int k = 0; k < 3; ++k) {
      int a = tris_[3 * t + k], b = tris_[3 * t + (k + 1) % 3], c = tris_[3 * t + (k + 2) % 3];
      if (a > b) std::swap(a, b);
      rec.push_back({int64_t(a) * n_ + b, t, c});
    }
  std::sort(rec.begin(), rec.end(), [](const Rec& u, const Rec& v) { return u.key < v.key || (u.key == v.key && u.tri < v.tri); });
  spring_v_.clear();
  hinge_v_.clear();
  for (size_t s = 0; s < rec.size();) {
    size_t e = s;
    while (e < rec.size() && rec[e].key == rec[s].key) ++e;
    const int a = int(rec[s].key / n_), b = int(rec[s].key % n_);
    spring_v_.push_back(a);
    spring_v_.push_back(b);
    // Hinges only on manifold interior edges.
    if (e - s == 2 && rec[s].opp != rec[s + 1].opp) {
      hinge_v_.insert(hinge_v_.end(), {a, b, rec[s].opp, rec[s + 1].opp});
    }
    s = e;
  }
  // Sewing pairs: drop self pairs and duplicates.
  std::vector<int64_t> sk;
  for (int k = 0; k < n_sew; ++k) {
    int a = sew[2 * k], b = sew[2 * k + 1];
    if (a < 0 || b < 0 || a >= n_ || b >= n_)
      throw SimError("simulator: sewing pair " + std::to_string(k) + " has a vertex index out of range");
    if (a == b) continue;
    if (a > b) std::swap(a, b);
    sk.push_back(int64_t(a) * n_ + b);
  }
  std::sort(sk.begin(), sk.end());
  sk.erase(std::unique(sk.begin(), sk.end()), sk.end());
  sew_v_.clear();
  for (int64_t k : sk) {
    sew_v_.push_back(int32_t(k / n_));
    sew_v_.push_back(int32_t(k % n_));
  }
  // Neighbour pattern (self, springs, sewing, hinge stencils).
  std::vector<int64_t> pairs;
  pairs.reserve(size_t(n_) + 2 * spring_v_.size() + 2 * sew_v_.size() + 12 * size_t(n_hinges()));
  for (int v = 0; v < n_; ++v) pairs.push_back(int64_t(v) * n_ + v);
  auto add_pair = [&](int a, int b) {
    pairs.push_back(int64_t(a) * n_ + b);
    pairs.push_back(int64_t(b) * n_ + a);
  };
  for (size_t e = 0; e < spring_v_.size(); e += 2) add_pair(spring_v_[e], spring_v_[e + 1]);
  for (size_t e = 0; e < sew_v_.size(); e += 2) add_pair(sew_v_[e], sew_v_[e + 1]);
  for (int h = 0; h < n_hinges(); ++h)
    for (int k = 0; k < 4; ++k)
      for (int l = k + 1; l < 4; ++l) add_pair(hinge_v_[4 * h + k], hinge_v_[4 * h + l]);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  nbr_ptr_.assign(n_ + 1, 0);
  nbr_idx_.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    nbr_ptr_[int(pairs[k] / n_) + 1]++;
    nbr_idx_[k] = int32_t(pairs[k] % n_);
  }
  for (int v = 0; v < n_; ++v) nbr_ptr_[v + 1] += nbr_ptr_[v];
  self_slot_.resize(n_);
  for (int v = 0; v < n_; ++v) self_slot_[v] = slot_of(v, v);
  // Incidence lists.
  {
    std::vector<int32_t> keys(spring_v_.begin(), spring_v_.end()), order;
    build_csr(n_, keys, vs_ptr_, order);
    vs_idx_.resize(order.size());
    vs_slot_.resize(order.size());
    for (size_t k = 0; k < order.size(); ++k) vs_idx_[k] = order[k];  // e*2 + side
    for (int v = 0; v < n_; ++v)
      for (int k = vs_ptr_[v]; k < vs_ptr_[v + 1]; ++k) {
        const int e = vs_idx_[k] >> 1, side = vs_idx_[k] & 1;
        vs_slot_[k] = slot_of(v, spring_v_[2 * e + (1 - side)]);
      }
  }
  {
    std::vector<int32_t> keys(sew_v_.begin(), sew_v_.end()), order;
    build_csr(n_, keys, vw_ptr_, order);
    vw_idx_.resize(order.size());
    vw_slot_.resize(order.size());
    for (int v = 0; v < n_; ++v)
      for (int k = vw_ptr_[v]; k < vw_ptr_[v + 1]; ++k) {
        const int e = order[k] >> 1, side = order[k] & 1;
        vw_idx_[k] = sew_v_[2 * e + (1 - side)];
        vw_slot_[k] = slot_of(v, vw_idx_[k]);
      }
  }
  {
    std::vector<int32_t> keys(hinge_v_.begin(), hinge_v_.end()), order;
    build_csr(n_, keys, vh_ptr_, order);
    vh_idx_ = order;  // h*4 + k
  }
  {
    std::vector<int32_t> keys(tris_.begin(), tris_.end()), order;
    build_csr(n_, keys, vt_ptr_, order);
    vt_idx_ = order;  // t*3 + k
  }
  spring_g_.resize(n_springs());
  spring_H_.resize(n_springs());
}

int Simulator::slot_of(int v, int u) const { return neighbour_slot(nbr_ptr_.data(), nbr_idx_.data(), v, u); }

void Simulator::build_hessian_pattern() {
  // Column 3v+a holds rows 3u+b for u in nbr(v) (sorted), b = 0..2, so the
  // value of block (u, v) entry (b, a) sits at outer[3v+a] + 3*slot(v,u) + b.
  const int n3 = 3 * n_;
  std::vector<int> outer(n3 + 1, 0);
  for (int v = 0; v < n_; ++v)
    for (int a = 0; a < 3; ++a) outer[3 * v + a + 1] = 3 * (nbr_ptr_[v + 1] - nbr_ptr_[v]);
  for (int c = 0; c < n3; ++c) outer[c + 1] += outer[c];
  H_.resize(n3, n3);
  H_.resizeNonZeros(outer[n3]);
  std::copy(outer.begin(), outer.end(), H_.outerIndexPtr());
  int* inner = H_.innerIndexPtr();
  for (int v = 0; v < n_; ++v)
    for (int a = 0; a < 3; ++a) {
      int pos = outer[3 * v + a];
      for (int k = nbr_ptr_[v]; k < nbr_ptr_[v + 1]; ++k)
        for (int b = 0; b < 3; ++b) inner[pos++] = 3 * nbr_idx_[k] + b;
    }
  std::fill(H_.valuePtr(), H_.valuePtr() + outer[n3], 0.0);
}

void Simulator::set_sdf(const float* values, int nx, int ny, int nz, const double origin[3], double spacing) {
  if (nx < 2 || ny < 2 || nz < 2) throw SimError("simulator: the SDF grid needs at least 2 nodes per axis");
  sdf_values_.assign(values, values + size_t(nx) * ny * nz);
  set_sdf_view(sdf_values_.data(), nx, ny, nz, origin, spacing);
}

void Simulator::set_sdf_view(const float* values, int nx, int ny, int nz, const double origin[3], double spacing) {
  if (nx < 2 || ny < 2 || nz < 2) throw SimError("simulator: the SDF grid needs at least 2 nodes per axis");
  if (!(spacing > 0) || !std::isfinite(spacing)) throw SimError("simulator: the SDF spacing must be positive");
  const size_t count = size_t(nx) * ny * nz;
  bool finite = true;
#pragma omp parallel for reduction(&& : finite) schedule(static) num_threads(threads_)
  for (long long i = 0; i < (long long)count; ++i) finite = finite && std::isfinite(values[i]);
  if (!finite) throw SimError("simulator: the SDF has non-finite values");
  if (values != sdf_values_.data()) sdf_values_.clear();
  sdf_.values = values;
  sdf_.nx = nx;
  sdf_.ny = ny;
  sdf_.nz = nz;
  for (int a = 0; a < 3; ++a) sdf_.origin[a] = origin[a];
  sdf_.spacing = spacing;
  has_sdf_ = true;
  ++sdf_revision_;
}

void Simulator::clear_sdf() {
  has_sdf_ = false;
  sdf_values_.clear();
  sdf_ = SdfGridView();
  ++sdf_revision_;
}

SimArrays Simulator::arrays() const {
  SimArrays a;
  a.n = n_;
  a.n_springs = n_springs();
  a.spring_v = spring_v_.data();
  a.vs_ptr = vs_ptr_.data();
  a.vs_idx = vs_idx_.data();
  a.vw_ptr = vw_ptr_.data();
  a.vw_idx = vw_idx_.data();
  a.nbr_ptr = nbr_ptr_.data();
  a.nbr_idx = nbr_idx_.data();
  a.self_slot = self_slot_.data();
  a.rest_L = rest_L_.data();
  a.shirring = shirring_.data();
  a.Q = Q_.data();
  a.mass = mass_.data();
  a.barrier_c = barrier_c_.data();
  a.stick_k = stick_k_.data();
  a.stick_t = stick_t_.data();
  a.any_sticking = any_sticking_;
  a.p = p_.data();
  a.n_tris = n_triangles();
  a.n_hinges = n_hinges();
  a.tris = tris_.data();
  a.vt_ptr = vt_ptr_.data();
  a.vt_idx = vt_idx_.data();
  a.hinge_v = hinge_v_.data();
  a.vh_ptr = vh_ptr_.data();
  a.vh_idx = vh_idx_.data();
  a.L_floored = L_floored_.data();
  a.m_floor = m_floor_;
  a.L_floor = L_floor_;
  a.rest_stale = rest_stale_;
  a.rest_revision = rest_revision_;
  a.shirring_revision = shirring_revision_;
  a.sticking_revision = sticking_revision_;
  a.has_sdf = has_sdf_;
  a.sdf = sdf_;
  a.sdf_revision = sdf_revision_;
  return a;
}

SdfSample Simulator::sdf_at(Vec3 p) const { return barrier_field(sdf_, params_.barrier_smooth, p); }

Sym3 Simulator::sdf_hess_at(Vec3 p) const {
  return params_.barrier_smooth ? sdf_sample_smooth<true>(sdf_, p).hess : sdf_hessian(sdf_, p);
}

void Simulator::set_params(const SimParams& params) {
  const bool mass_changed = params.density != params_.density;
  if (params.mu > 0 && !(params.barrier_distance > 0))
    throw SimError("simulator: the barrier distance must be positive");
  const bool barrier_changed = params.mu != params_.mu || params.barrier_length != params_.barrier_length;
  params_ = params;
  if (mass_changed || barrier_changed) ++rest_revision_;
  if (rest_stale_) return;  // rebuilt from these parameters on first use
  if (mass_changed) update_rest_state();
  if (mass_changed || barrier_changed) update_barrier_weights();
}

void Simulator::set_pattern(const double* p) {
  for (int i = 0; i < 2 * n_; ++i)
    if (!std::isfinite(p[i])) throw SimError("simulator: pattern coordinate " + std::to_string(i / 2) + " is not finite");
  p_.assign(p, p + 2 * n_);
  // The rest state follows on first use on the CPU: a search whose simulations run
  // on the GPU recomputes it there from p (sim_gpu.cu) and need not pay for it here.
  rest_stale_ = true;
  ++rest_revision_;
}

void Simulator::ensure_rest_state() const {
  if (!rest_stale_) return;
  auto* self = const_cast<Simulator*>(this);  // a cache of p's consequences, not a change of state
  self->update_rest_state();
  self->update_barrier_weights();
  rest_stale_ = false;
}

void Simulator::set_shirring(const double* r) {
  for (int e = 0; e < n_springs(); ++e) {
    if (!(r[e] > 0) || !std::isfinite(r[e]))
      throw SimError("simulator: shirring scale of spring " + std::to_string(e) + " must be positive");
  }
  shirring_.assign(r, r + n_springs());
  ++shirring_revision_;
}

void Simulator::set_sticking(const double* k, const double* targets) {
  ++sticking_revision_;
  any_sticking_ = false;
  for (int v = 0; v < n_; ++v) {
    if (!(k[v] >= 0) || !std::isfinite(k[v])) throw SimError("simulator: sticking stiffness must be >= 0");
    stick_k_[v] = k[v];
    if (k[v] > 0) any_sticking_ = true;
    for (int a = 0; a < 3; ++a) {
      if (k[v] > 0 && !std::isfinite(targets[3 * v + a]))
        throw SimError("simulator: sticking target of vertex " + std::to_string(v) + " is not finite");
      stick_t_[3 * v + a] = k[v] > 0 ? targets[3 * v + a] : 0.0;
    }
  }
}

void Simulator::update_rest_state() {
  const int E = n_springs(), T = n_triangles(), Hn = n_hinges();
  rest_L_.resize(E);
  L_floored_.assign(E, 0);
  for (int e = 0; e < E; ++e)
    rest_L_[e] = spring_rest_length(p_.data(), spring_v_[2 * e], spring_v_[2 * e + 1], L_floor_, &L_floored_[e]);
  tri_area_.resize(T);
  for (int t = 0; t < T; ++t) tri_area_[t] = triangle_rest_area(p_.data(), &tris_[3 * t]);
  mass_.resize(n_);
  for (int v = 0; v < n_; ++v) mass_[v] = vertex_mass(v, vt_ptr_.data(), vt_idx_.data(), tri_area_.data(), params_.density);
  double s2 = 0;
  for (double m : mass_) s2 += m * m;
  weight_norm_ = kG0 * std::sqrt(s2);
  if (!(weight_norm_ > 0)) weight_norm_ = 1.0;  // massless cloth: absolute residual
  hinge_K_.assign(4 * size_t(Hn), 0.0);
  hinge_w_.assign(Hn, 0.0);
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int h = 0; h < Hn; ++h) hinge_rest(p_.data(), &hinge_v_[4 * h], &hinge_K_[4 * h], &hinge_w_[h]);
  // Q on the neighbour pattern, gathered per vertex.
  Q_.assign(nbr_idx_.size(), 0.0);
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v)
    bending_q_row(v, vh_ptr_.data(), vh_idx_.data(), hinge_v_.data(), hinge_K_.data(), hinge_w_.data(), nbr_ptr_.data(),
                  nbr_idx_.data(), Q_.data() + nbr_ptr_[v]);
}

void Simulator::update_barrier_weights() {
  barrier_c_.resize(n_);
  const double s = params_.mu * params_.barrier_length * kG0;
  for (int v = 0; v < n_; ++v) barrier_c_[v] = barrier_weight(mass_[v], m_floor_, s);
}

void Simulator::set_threads(int threads) {
  // Below a few thousand vertices a parallel region costs more than it saves
  // (and much more on a loaded machine).
  constexpr int kParallelMinVertices = 3000;
  if (threads > 0) threads_ = threads;
  else threads_ = n_ < kParallelMinVertices ? 1 : std::max(1, omp_get_max_threads());
}

double Simulator::projection_gap() const {
  // The rest gap of a vertex pressed by its own weight, bounded to a sane range.
  const double g = std::min(std::max(params_.mu * params_.barrier_length, 1e-5), 5e-3);
  return std::min(g, 0.5 * params_.barrier_distance);
}

int Simulator::first_inside(const double* x, double* phi_out) const {
  if (!barrier_on()) return -1;
  for (int v = 0; v < n_; ++v) {
    const SdfSample s = sdf_at(vget(x, v));
    if (!(s.phi > 0)) {
      if (phi_out) *phi_out = s.phi;
      return v;
    }
  }
  return -1;
}

void Simulator::sample_phi(const double* x, double* phi, bool barrier_field) const {
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v) {
    if (!has_sdf_) phi[v] = std::numeric_limits<double>::infinity();
    else phi[v] = barrier_field ? sdf_at(vget(x, v)).phi : sdf_sample(sdf_, vget(x, v)).phi;
  }
}

void Simulator::evaluate(const double* x, double* f, EnergyTerms* terms, Sym3* diag, SdfSample* samples,
                         bool samples_known, bool reuse_spring_diag) {
  const int E = n_springs();
  const double Y = params_.stretch_Y, Ys = params_.sewing_Y, kb = params_.bend_kb;
  const Vec3 gv = params_.gravity;
  const bool grav = params_.density > 0 && norm2(gv) > 0;
  const bool bar = barrier_on();
  const bool stick = any_sticking_;
  const double dhat = params_.barrier_distance;
  double e_stretch = 0;
  if (Y > 0) {
#pragma omp parallel for reduction(+ : e_stretch) schedule(static) num_threads(threads_)
    for (int e = 0; e < E; ++e) {
      const Vec3 xi = vget(x, spring_v_[2 * e]), xj = vget(x, spring_v_[2 * e + 1]);
      const double L = rest_L_[e], r = shirring_[e];
      e_stretch += patch_spring_energy(xi, xj, L, r, Y);
      spring_g_[e] = patch_spring_grad(xi, xj, L, r, Y);
      if (diag && !reuse_spring_diag) spring_H_[e] = patch_spring_hess(xi, xj, L, r, Y, true);
    }
  }
  double e_sew = 0, e_bend = 0, e_grav = 0, e_stick = 0, e_bar = 0;
#pragma omp parallel for reduction(+ : e_sew, e_bend, e_grav, e_stick, e_bar) schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v) {
    const Vec3 xv = vget(x, v);
    Vec3 g = make_vec3(0, 0, 0);
    Sym3 D = sym3_zero();
    if (Y > 0) {
      for (int k = vs_ptr_[v]; k < vs_ptr_[v + 1]; ++k) {
        const int e = vs_idx_[k] >> 1;
        if (vs_idx_[k] & 1) g -= spring_g_[e]; else g += spring_g_[e];
        if (diag) D += spring_H_[e];
      }
    }
    if (Ys > 0) {
      for (int k = vw_ptr_[v]; k < vw_ptr_[v + 1]; ++k) {
        const Vec3 xu = vget(x, vw_idx_[k]);
        g += sewing_spring_grad(xv, xu, Ys);
        e_sew += 0.5 * sewing_spring_energy(xv, xu, Ys);  // each pair is visited twice
      }
      if (diag) D += sym3_identity(Ys * (vw_ptr_[v + 1] - vw_ptr_[v]));
    }
    if (kb > 0) {
      Vec3 qx = make_vec3(0, 0, 0);
      for (int k = nbr_ptr_[v]; k < nbr_ptr_[v + 1]; ++k) qx += Q_[k] * vget(x, nbr_idx_[k]);
      g += kb * qx;
      e_bend += 0.5 * kb * dot(xv, qx);
      if (diag) D += sym3_identity(kb * Q_[nbr_ptr_[v] + self_slot_[v]]);
    }
    if (grav) {
      e_grav += gravity_energy(mass_[v], gv, xv);
      g += gravity_grad(mass_[v], gv);
    }
    if (stick && stick_k_[v] > 0) {
      const Vec3 t = vget(stick_t_.data(), v);
      e_stick += sticking_energy(stick_k_[v], xv, t);
      g += sticking_grad(stick_k_[v], xv, t);
      if (diag) D += sym3_identity(stick_k_[v]);
    }
    if (bar) {
      const SdfSample s = samples_known ? samples[v] : sdf_at(xv);
      if (samples && !samples_known) samples[v] = s;
      const double c = barrier_c_[v];
      if (s.phi > 0) {
        e_bar += barrier_energy(c, dhat, s.phi);
        g += barrier_grad(c, dhat, s);
        if (diag) D += barrier_hess_psd(c, dhat, s);
      } else {
        e_bar += std::numeric_limits<double>::infinity();
      }
    }
    if (f) vset(f, v, -g);
    if (diag) diag[v] = D;
  }
  if (terms) {
    terms->stretch = e_stretch;
    terms->sewing = e_sew;
    terms->bending = e_bend;
    terms->gravity = e_grav;
    terms->sticking = e_stick;
    terms->barrier = e_bar;
  }
}

double Simulator::energy(const double* x, EnergyTerms* terms) {
  ensure_rest_state();
  EnergyTerms t;
  scratch_.resize(3 * size_t(n_));
  evaluate(x, scratch_.data(), &t, nullptr, nullptr);
  if (terms) *terms = t;
  return t.total();
}

double Simulator::force(const double* x, double* f, EnergyTerms* terms) {
  ensure_rest_state();
  EnergyTerms t;
  evaluate(x, f, &t, nullptr, nullptr);
  if (terms) *terms = t;
  return t.total();
}

double Simulator::residual(const double* f) const {
  ensure_rest_state();
  double s = 0;
#pragma omp parallel for reduction(+ : s) schedule(static) num_threads(threads_)
  for (int i = 0; i < 3 * n_; ++i) s += f[i] * f[i];
  return std::sqrt(s) / weight_norm_;
}

const Eigen::SparseMatrix<double>& Simulator::hessian(const double* x, bool psd) {
  ensure_rest_state();
  const int E = n_springs();
  const double Y = params_.stretch_Y, Ys = params_.sewing_Y, kb = params_.bend_kb;
  const bool bar = barrier_on();
  if (Y > 0) {
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int e = 0; e < E; ++e)
      spring_H_[e] = patch_spring_hess(vget(x, spring_v_[2 * e]), vget(x, spring_v_[2 * e + 1]), rest_L_[e], shirring_[e], Y, psd);
  }
  const int* outer = H_.outerIndexPtr();
  double* val = H_.valuePtr();
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v) {
    const int deg = nbr_ptr_[v + 1] - nbr_ptr_[v];
    for (int a = 0; a < 3; ++a) std::fill(val + outer[3 * v + a], val + outer[3 * v + a] + 3 * deg, 0.0);
    auto add = [&](int slot, const Sym3& B, double sign) {
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) val[outer[3 * v + a] + 3 * slot + b] += sign * sym3_get(B, a, b);
    };
    auto add_iso = [&](int slot, double s) {
      for (int a = 0; a < 3; ++a) val[outer[3 * v + a] + 3 * slot + a] += s;
    };
    const int self = self_slot_[v];
    if (Y > 0)
      for (int k = vs_ptr_[v]; k < vs_ptr_[v + 1]; ++k) {
        const Sym3& He = spring_H_[vs_idx_[k] >> 1];
        add(self, He, 1.0);
        add(vs_slot_[k], He, -1.0);
      }
    if (Ys > 0)
      for (int k = vw_ptr_[v]; k < vw_ptr_[v + 1]; ++k) {
        add_iso(self, Ys);
        add_iso(vw_slot_[k], -Ys);
      }
    if (kb > 0)
      for (int k = 0; k < deg; ++k) add_iso(k, kb * Q_[nbr_ptr_[v] + k]);
    if (any_sticking_ && stick_k_[v] > 0) add_iso(self, stick_k_[v]);
    if (bar) {
      const Vec3 xv = vget(x, v);
      const SdfSample s = sdf_at(xv);
      if (s.phi > 0) {
        const double c = barrier_c_[v], dh = params_.barrier_distance;
        add(self, psd ? barrier_hess_psd(c, dh, s) : barrier_hess(c, dh, s, sdf_hess_at(xv)), 1.0);
      }
    }
  }
  return H_;
}

void Simulator::hess_vec(const double* x, const double* vin, double* out, bool psd) {
  ensure_rest_state();
  const int E = n_springs();
  const double Y = params_.stretch_Y, Ys = params_.sewing_Y, kb = params_.bend_kb;
  const bool bar = barrier_on();
  if (Y > 0) {
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int e = 0; e < E; ++e) {
      const int i = spring_v_[2 * e], j = spring_v_[2 * e + 1];
      const Sym3 He = patch_spring_hess(vget(x, i), vget(x, j), rest_L_[e], shirring_[e], Y, psd);
      spring_g_[e] = He * (vget(vin, i) - vget(vin, j));
    }
  }
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v) {
    const Vec3 vv = vget(vin, v);
    Vec3 r = make_vec3(0, 0, 0);
    if (Y > 0)
      for (int k = vs_ptr_[v]; k < vs_ptr_[v + 1]; ++k) {
        const int e = vs_idx_[k] >> 1;
        if (vs_idx_[k] & 1) r -= spring_g_[e]; else r += spring_g_[e];
      }
    if (Ys > 0)
      for (int k = vw_ptr_[v]; k < vw_ptr_[v + 1]; ++k) r += Ys * (vv - vget(vin, vw_idx_[k]));
    if (kb > 0)
      for (int k = nbr_ptr_[v]; k < nbr_ptr_[v + 1]; ++k) r += (kb * Q_[k]) * vget(vin, nbr_idx_[k]);
    if (any_sticking_ && stick_k_[v] > 0) r += stick_k_[v] * vv;
    if (bar) {
      const Vec3 xv = vget(x, v);
      const SdfSample s = sdf_at(xv);
      if (s.phi > 0) {
        const double c = barrier_c_[v], dh = params_.barrier_distance;
        r += (psd ? barrier_hess_psd(c, dh, s) : barrier_hess(c, dh, s, sdf_hess_at(xv))) * vv;
      }
    }
    vset(out, v, r);
  }
}

void Simulator::dfdp_T(const double* x, const double* lam, double* out) {
  ensure_rest_state();
  const int E = n_springs(), Hn = n_hinges(), T = n_triangles();
  const double Y = params_.stretch_Y, kb = params_.bend_kb;
  const Vec3 gv = params_.gravity;
  const bool bar = barrier_on();
  const bool mass_terms = params_.density > 0 && (norm2(gv) > 0 || bar);
  // Scratch layout: springs (2E) | hinges (8H) | triangles (6T) | vertex weights (n).
  const size_t o_s = 0, o_h = o_s + (Y > 0 ? 2 * size_t(E) : 0), o_t = o_h + (kb > 0 ? 8 * size_t(Hn) : 0),
               o_w = o_t + (mass_terms ? 6 * size_t(T) : 0), total = o_w + (mass_terms ? size_t(n_) : 0);
  scratch_.assign(total, 0.0);
  double* sp = scratch_.data() + o_s;
  double* hp = scratch_.data() + o_h;
  double* tp = scratch_.data() + o_t;
  double* wv = scratch_.data() + o_w;
  if (Y > 0) {
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int e = 0; e < E; ++e) {
      const int i = spring_v_[2 * e], j = spring_v_[2 * e + 1];
      if (L_floored_[e]) { sp[2 * e] = sp[2 * e + 1] = 0; continue; }
      patch_spring_dfdp_T(vget(x, i), vget(x, j), vget(lam, i), vget(lam, j), p_[2 * i], p_[2 * i + 1], p_[2 * j],
                          p_[2 * j + 1], rest_L_[e], shirring_[e], Y, sp + 2 * e);
    }
  }
  if (kb > 0) {
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int h = 0; h < Hn; ++h) {
      const int* hv = &hinge_v_[4 * h];
      double pp[8];
      Vec3 xx[4], ll[4];
      for (int k = 0; k < 4; ++k) {
        pp[2 * k] = p_[2 * hv[k]];
        pp[2 * k + 1] = p_[2 * hv[k] + 1];
        xx[k] = vget(x, hv[k]);
        ll[k] = vget(lam, hv[k]);
      }
      hinge_dfdp_T(pp, xx, ll, kb, hp + 8 * h);
    }
  }
  if (mass_terms) {
    // d(lam . f)/dm_v for gravity and the mass-scaled barrier.
    const double sb = params_.mu * params_.barrier_length * kG0;
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const bool b = bar && mass_[v] >= m_floor_;
      const SdfSample s = b ? sdf_at(vget(x, v)) : SdfSample{};
      wv[v] = dfdp_mass_weight(gv, vget(lam, v), b, s, sb, params_.barrier_distance);
    }
    const double rho3 = params_.density / 3.0;
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int t = 0; t < T; ++t) dfdp_triangle(p_.data(), &tris_[3 * t], wv, rho3, tp + 6 * t);
  }
#pragma omp parallel for schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v)
    dfdp_gather(v, vs_ptr_.data(), vs_idx_.data(), Y > 0 ? sp : nullptr, vh_ptr_.data(), vh_idx_.data(),
                kb > 0 ? hp : nullptr, vt_ptr_.data(), vt_idx_.data(), mass_terms ? tp : nullptr, out + 2 * v);
}

void Simulator::sewing_gaps(const double* x, double* gaps) const {
  for (int k = 0; k < n_sewing(); ++k) gaps[k] = norm(vget(x, sew_v_[2 * k]) - vget(x, sew_v_[2 * k + 1]));
}

int Simulator::project_outside(double* x, double floor, double target) const {
  if (!barrier_on()) return 0;
  int count = 0;
#pragma omp parallel for reduction(+ : count) schedule(static) num_threads(threads_)
  for (int v = 0; v < n_; ++v) {
    Vec3 p = vget(x, v);
    SdfSample s = sdf_at(p);
    if (s.phi >= floor) continue;
    ++count;
    // Newton steps on phi(p) = target along the field gradient.
    for (int it = 0; it < 8 && s.phi < 0.5 * (floor + target); ++it) {
      double g2 = norm2(s.grad);
      Vec3 dir = s.grad;
      if (g2 < 1e-12) { dir = make_vec3(0, 0, 1); g2 = 1; }  // flat spot of the field
      p += ((target - s.phi) / g2) * dir;
      s = sdf_at(p);
    }
    vset(x, v, p);
  }
  return count;
}

SolveReport Simulator::solve(double* x, const SolveSettings& s, const ProgressFn& progress,
                             const std::atomic<bool>* cancel, const NewtonStepFn& step) {
  ensure_rest_state();
  for (int i = 0; i < 3 * n_; ++i)
    if (!std::isfinite(x[i])) throw SimError("simulator: start position of vertex " + std::to_string(i / 3) + " is not finite");
  if (s.method == 1) return solve_newton(x, s, progress, cancel, step);
  return solve_chebyshev(x, s, progress, cancel);
}

}  // namespace seamfit::sim
