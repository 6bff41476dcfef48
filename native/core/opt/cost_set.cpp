#include "opt/cost_set.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "opt/costs/gather.hpp"

namespace seamfit::opt {

namespace {

void set_elements(CostElements& el, int arity, const int* ids, int count, int n) {
  el.count = count;
  el.arity = arity;
  el.ids.assign(ids, ids + size_t(arity) * count);
  el.gather.build(count ? el.ids.data() : nullptr, count, arity, n);
}

}  // namespace

CostSet::CostSet(int n_vertices, const std::vector<Tri>& tris, const Vec2* pbar, const Vec3* xbar)
    : n_(n_vertices) {
  for (const Tri& t : tris)
    for (int v : t)
      if (v < 0 || v >= n_) throw std::invalid_argument("triangle index out of range");
  elements_[kVertices].count = n_;  // element i is vertex i: no ids, no gather
  const std::vector<Edge> edges = unique_edges(tris);
  for (const Edge& e : edges)
    if (!(norm(pbar[e[0]] - pbar[e[1]]) > 0)) throw std::invalid_argument("zero-length edge in the base pattern");
  set_elements(elements_[kEdges], 2, edges.empty() ? nullptr : &edges[0][0], int(edges.size()), n_);
  std::vector<Hinge> hinges = interior_hinges(tris);
  // Sliver hinges carry no smoothness cost (as they carry no bending in the simulator).
  hinges.erase(std::remove_if(hinges.begin(), hinges.end(), [&](const Hinge& h) { return !hinge_well_shaped(h, pbar); }),
               hinges.end());
  set_elements(elements_[kHinges], 4, hinges.empty() ? nullptr : &hinges[0][0], int(hinges.size()), n_);
  // The constants each term computes from the base garment and pattern.
  const BaseGarment base{pbar, xbar};
  for (int q = 0; q < kNumCostTerms; ++q)
    visit_cost_term(CostTerm(q), [&](auto term) {
      using T = decltype(term);
      if constexpr (T::kInput == nullptr) {
        const CostElements& el = elements_[T::kOn];
        std::vector<double>& c = constants_[q];
        c.resize(size_t(T::kWidth) * el.count);
        for (int e = 0; e < el.count; ++e)
          T::base(base, T::kOn == kVertices ? &e : &el.ids[size_t(el.arity) * e], &c[size_t(T::kWidth) * e]);
        ready_[q] = true;
      }
    });
}

const CostElements& CostSet::elements(CostTerm t) const {
  Elements kind = kVertices;
  visit_cost_term(t, [&](auto term) { kind = decltype(term)::kOn; });
  return elements_[kind];
}

int CostSet::width(CostTerm t) const {
  int w = 0;
  visit_cost_term(t, [&](auto term) { w = decltype(term)::kWidth; });
  return w;
}

void CostSet::set_target_sdf(const SdfGridView& sdf) {
  if (!sdf.values || sdf.nx < 2 || sdf.ny < 2 || sdf.nz < 2 || !(sdf.spacing > 0))
    throw std::invalid_argument("invalid signed distance grid");
  sdf_ = sdf;
  has_sdf_ = true;
}

void CostSet::set_inputs(CostTerm t, const double* values) {
  if (t < 0 || t >= kNumCostTerms) throw std::invalid_argument("no such cost term");
  bool from_base = false;
  visit_cost_term(t, [&](auto term) { from_base = decltype(term)::kInput == nullptr; });
  if (from_base)
    throw std::invalid_argument(std::string("the ") + kCostTerms[t].name + " cost computes its constants itself");
  const size_t size = size_t(width(t)) * elements(t).count;
  constants_[t].assign(values, values + size);
  ready_[t] = true;
}

void check_cost_inputs(const CostStrengths& strengths, const bool* ready, bool has_sdf) {
  for (int q = 0; q < kNumCostTerms; ++q) {
    if (strengths[q] == 0) continue;
    visit_cost_term(CostTerm(q), [&](auto term) {
      using T = decltype(term);
      const char* missing = !ready[q] ? T::kInput : (T::kField && !has_sdf ? "target SDF" : nullptr);
      if (missing)
        throw std::logic_error(std::string(kCostTerms[q].label) + " cost has a strength but no " + missing);
    });
  }
}

CostSetView CostSet::view() const {
  CostSetView v;
  v.n = n_;
  for (int k = 0; k < kNumElementKinds; ++k) {
    const CostElements& el = elements_[k];
    auto& ev = v.elements[k];
    ev.count = el.count;
    ev.arity = el.arity;
    ev.ids = el.ids.empty() ? nullptr : el.ids.data();
    ev.offsets = el.gather.offsets.data();
    ev.slots = el.gather.slots.data();
  }
  for (int q = 0; q < kNumCostTerms; ++q) {
    v.constants[q] = constants_[q].empty() ? nullptr : constants_[q].data();
    v.ready[q] = ready_[q];
  }
  v.has_sdf = has_sdf_;
  v.sdf = sdf_;
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

// One term's value; its gradient added to gx and gp. A term over the vertices adds each
// vertex's gradient straight in; another writes its elements' gradient slots, which each
// vertex then adds in slot order. The GPU adds the same values in the same order.
template <class T>
double CostSet::accumulate(CostTerm t, const CostInputs& in, double k, Vec3* gx, Vec2* gp) {
  const CostElements& el = elements_[T::kOn];
  const int ne = el.count, a = el.arity, n = n_;
  const int* ids = el.ids.data();
  const double* c = constants_[t].data();
  val_.resize(ne);
  if constexpr (T::kOn == kVertices) {
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int i = 0; i < n; ++i) {
      Vec3 g;
      Vec2 q = make_vec2(0, 0);
      val_[i] = T::element(in, &i, c + size_t(T::kWidth) * i, k, &g, &q);
      gx[i] += g;
      if (T::kPattern) gp[i] += q;
    }
  } else {
    slot_x_.resize(size_t(a) * ne);
    if (T::kPattern) slot_p_.resize(size_t(a) * ne);
    Vec3* sx = slot_x_.data();
    Vec2* sp = T::kPattern ? slot_p_.data() : nullptr;
#pragma omp parallel for schedule(static) if (ne >= kParallelMin)
    for (int e = 0; e < ne; ++e)
      val_[e] = T::element(in, ids + size_t(a) * e, c + size_t(T::kWidth) * e, k, sx + size_t(a) * e,
                           sp ? sp + size_t(a) * e : nullptr);
    const int *off = el.gather.offsets.data(), *slots = el.gather.slots.data();
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int v = 0; v < n; ++v) {
      gather_add(v, off, slots, sx, gx[v]);
      if (T::kPattern) gather_add(v, off, slots, sp, gp[v]);
    }
  }
  return serial_sum(val_, ne);
}

double CostSet::evaluate(const Vec3* x, const Vec2* p, Vec3* gx, Vec2* gp, CostValues* terms) {
  check_inputs();
  const int n = n_;
  for (int i = 0; i < n; ++i) gx[i] = make_vec3(0, 0, 0);
  for (int i = 0; i < n; ++i) gp[i] = make_vec2(0, 0);
  CostInputs in;
  in.x = x;
  in.p = p;
  in.sdf = sdf_;
  CostValues t{};
  for (const CostTerm q : kCostGradientOrder) {
    const double k = strengths_[q];
    if (k == 0) continue;
    ++evals_[q];
    visit_cost_term(q, [&](auto term) { t[q] = accumulate<decltype(term)>(q, in, k, gx, gp); });
  }
  if (terms) *terms = t;
  double total = t[0];
  for (int q = 1; q < kNumCostTerms; ++q) total += t[q];
  return total;
}

}  // namespace seamfit::opt
