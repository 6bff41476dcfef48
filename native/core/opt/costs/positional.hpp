// Positional cost, Eq. 16: C = k/2 * u_i * |x_i - xtilde_i|^2 per garment vertex, with
// xtilde the base garment transferred onto the target body (Eq. 15). No pattern
// dependence. The caller folds delta_pos * u_i into ku.
#pragma once
#include "common/vec3.hpp"

namespace seamfit {

SF_HD double positional_cost(Vec3 x, Vec3 xtilde, double ku, Vec3* gx) {
  const Vec3 d = x - xtilde;
  *gx = ku * d;
  return 0.5 * ku * norm2(d);
}

}  // namespace seamfit
