// Positional cost, Eq. 16: C = k/2 * u_i * |x_i - xtilde_i|^2 per garment vertex, with
// xtilde the base garment transferred onto the target body (Eq. 15). No pattern
// dependence. The caller folds delta_pos * u_i into ku.
#pragma once
#include "common/vec3.hpp"
#include "opt/costs/term.hpp"

namespace seamfit {

SF_HD double positional_cost(Vec3 x, Vec3 xtilde, double ku, Vec3* gx) {
  const Vec3 d = x - xtilde;
  *gx = ku * d;
  return 0.5 * ku * norm2(d);
}

}  // namespace seamfit

namespace seamfit::opt::costs {

// C^pos over the vertices; the constants are xtilde_i (3) and u_i, supplied by the caller.
struct Positional {
  static constexpr Elements kOn = kVertices;
  static constexpr int kWidth = 4;
  static constexpr const char* kInput = "transferred garment";
  static constexpr bool kField = false, kPattern = false;
  static SF_HD double element(const CostInputs& in, const int* v, const double* c, double k, Vec3* gx, Vec2*) {
    return positional_cost(in.x[v[0]], make_vec3(c[0], c[1], c[2]), k * c[3], gx);
  }
};

}  // namespace seamfit::opt::costs
