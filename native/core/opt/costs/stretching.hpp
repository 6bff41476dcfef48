// Stretching cost, Eq. 14, per pattern edge e = (i, j):
//   C = k/2 * (|x_i - x_j| / |p_i - p_j| - rbar_e)^2,
// rbar_e = |xbar_i - xbar_j| / |pbar_i - pbar_j| the base garment's stretch ratio.
// Depends on the garment x (3D) and on the pattern p (2D), both in metres.
#pragma once
#include "common/vec3.hpp"
#include "opt/costs/term.hpp"
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

namespace seamfit::opt::costs {

// C^str over the edges; the constant is rbar_e.
struct Stretching {
  static constexpr Elements kOn = kEdges;
  static constexpr int kWidth = 1;
  static constexpr const char* kInput = nullptr;
  static constexpr bool kField = false, kPattern = true;
  static void base(const BaseGarment& b, const int* v, double* c) {
    c[0] = norm(b.xbar[v[0]] - b.xbar[v[1]]) / norm(b.pbar[v[0]] - b.pbar[v[1]]);
  }
  static SF_HD double element(const CostInputs& in, const int* v, const double* c, double k, Vec3* gx, Vec2* gp) {
    return stretching_cost(in.x[v[0]], in.x[v[1]], in.p[v[0]], in.p[v[1]], c[0], k, &gx[0], &gx[1], &gp[0], &gp[1]);
  }
};

}  // namespace seamfit::opt::costs
