// The fitting cost terms C of Section 6, each registered once, here: the CPU and GPU cost
// sets, the bindings and through them seamfit.opt.costs.Strengths, the command line and
// the add-on all iterate over this list. A new term is its header under opt/costs/ (its
// energy and its struct, opt/costs/term.hpp), an include and a line below, its test and its
// row in docs/optimizer.md's costs table (docs/architecture.md, "Adding a cost term").
#pragma once
#include <array>
#include <cstring>

#include "opt/costs/distance.hpp"
#include "opt/costs/positional.hpp"
#include "opt/costs/smoothness.hpp"
#include "opt/costs/stretching.hpp"

// X(Term, name, order, label, help), in the paper's order, which is the order of the
// per-term values and of their sum:
//   Term         its struct in opt/costs/ (namespace seamfit::opt::costs)
//   name         the key of its strength and of its value and evaluation count
//   order        when its gradient joins each vertex's sum, 0 first; kept as the terms were
//                validated (results stay bit for bit), a new term takes the next number
//   label, help  how the command line and the add-on describe its strength
#define SEAMFIT_COST_TERMS(X)                                                                   \
  X(Distance, "dis", 0, "Distance", "Keeps the looseness of the garment per vertex")           \
  X(Smoothness, "smo", 3, "Smoothness", "Keeps folds and smoothness of the surface")           \
  X(Stretching, "str", 2, "Stretching", "Keeps the stretch ratio of every edge")               \
  X(Positional, "pos", 1, "Positional", "Keeps every garment point where it sits on the body")

namespace seamfit::opt {

enum CostTerm {
#define SEAMFIT_COST_ENUM(T, ...) k##T,
  SEAMFIT_COST_TERMS(SEAMFIT_COST_ENUM)
#undef SEAMFIT_COST_ENUM
  kNumCostTerms
};

struct CostTermInfo {
  const char* name;
  int order;
  const char* label;
  const char* help;
};

constexpr CostTermInfo kCostTerms[kNumCostTerms] = {
#define SEAMFIT_COST_INFO(T, name, order, label, help) {name, order, label, help},
    SEAMFIT_COST_TERMS(SEAMFIT_COST_INFO)
#undef SEAMFIT_COST_INFO
};

// The terms by `order`: the sequence in which their gradients are summed.
constexpr std::array<CostTerm, kNumCostTerms> cost_gradient_order() {
  std::array<CostTerm, kNumCostTerms> by_order{};
  for (int t = 0; t < kNumCostTerms; ++t)
    if (kCostTerms[t].order >= 0 && kCostTerms[t].order < kNumCostTerms) by_order[kCostTerms[t].order] = CostTerm(t);
  return by_order;
}
constexpr std::array<CostTerm, kNumCostTerms> kCostGradientOrder = cost_gradient_order();

constexpr bool cost_orders_distinct() {
  for (int t = 0; t < kNumCostTerms; ++t)
    if (kCostTerms[kCostGradientOrder[t]].order != t) return false;
  return true;
}
static_assert(cost_orders_distinct(), "each cost term needs its own order, 0 to the number of terms - 1");

// CostTermType<t>::type: the struct registered as t.
template <CostTerm t>
struct CostTermType;
#define SEAMFIT_COST_TYPE(T, ...) \
  template <>                     \
  struct CostTermType<k##T> {     \
    using type = costs::T;        \
  };
SEAMFIT_COST_TERMS(SEAMFIT_COST_TYPE)
#undef SEAMFIT_COST_TYPE

// f(term) with term a value of the struct registered as t.
template <class F>
void visit_cost_term(CostTerm t, F&& f) {
  switch (t) {
#define SEAMFIT_COST_CASE(T, ...) \
  case k##T:                      \
    f(costs::T{});                \
    break;
    SEAMFIT_COST_TERMS(SEAMFIT_COST_CASE)
#undef SEAMFIT_COST_CASE
    default:
      break;
  }
}

// The term called name (kNumCostTerms when none is).
inline CostTerm cost_term_named(const char* name) {
  for (int t = 0; t < kNumCostTerms; ++t)
    if (std::strcmp(kCostTerms[t].name, name) == 0) return CostTerm(t);
  return kNumCostTerms;
}

}  // namespace seamfit::opt
