// Stretching cost, Eq. 14, per pattern edge e = (i, j):
//   C = k/2 * (|x_i - x_j| / |p_i - p_j| - rbar_e)^2,
// rbar_e = |xbar_i - xbar_j| / |pbar_i - pbar_j| the base garment's stretch ratio.
// Depends on the garment x (3D) and on the pattern p (2D), both in metres.
#pragma once
#include "common/vec3.hpp"
#include "opt/vec2.hpp"

namespace seamfit {

SF_HD double stretching_cost(Vec3 xi, Vec3 xj, Vec2 pi, Vec2 pj, double rbar, double k,
                             Vec3* gxi, Vec3* gxj, Vec2* gpi, Vec2* gpj) {
  const Vec3 dx = xi - xj;
  const Vec2 dp = pi - pj;
  const double lx = norm(dx), lp = norm(dp);
  const double r = lx / lp - rbar;
  // d|dx|/dx_i = dx/|dx| (zero at the kink |dx| = 0, a valid subgradient).
  const Vec3 gx = lx > 0 ? (k * r / (lp * lx)) * dx : make_vec3(0, 0, 0);
  // d(1/|dp|)/dp_i = -dp/|dp|^3.
  const Vec2 gp = (-k * r * lx / (lp * lp * lp)) * dp;
  *gxi = gx;
  *gxj = -gx;
  *gpi = gp;
  *gpj = -gp;
  return 0.5 * k * r * r;
}

}  // namespace seamfit
