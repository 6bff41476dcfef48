// Patch springs and sewing springs (Wang 2018, Eq. 5).
//
// Patch spring s = (i, j) with pattern rest length L = |p_i - p_j| and shirring
// scale r:   E = Y / (2 L) * (l - r L)^2,   l = |x_i - x_j|.
// Sewing spring (zero rest length):   E = Ys / 2 * |x_i - x_j|^2.
//
// Every function returns quantities for endpoint i; endpoint j gets the negated
// gradient and the same Hessian block (H_ii = H_jj = -H_ij).
#pragma once
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"

namespace seamfit::sim {

// Below this length the spring direction is undefined; the force is then zero
// (its magnitude is bounded by Y r, the direction arbitrary) and the Hessian the
// isotropic Y/L, which is what the PSD projection tends to in that limit.
constexpr double kSpringTinyLength = 1e-12;

SF_HD double patch_spring_energy(Vec3 xi, Vec3 xj, double L, double r, double Y) {
  const double l = norm(xi - xj);
  const double s = l - r * L;
  return 0.5 * Y / L * s * s;
}

// dE/dx_i.
SF_HD Vec3 patch_spring_grad(Vec3 xi, Vec3 xj, double L, double r, double Y) {
  const Vec3 d = xi - xj;
  const double l = norm(d);
  if (l < kSpringTinyLength) return make_vec3(0, 0, 0);
  return (Y / L * (l - r * L) / l) * d;
}

// d2E/dx_i2 (exact when psd == false; with psd == true the transverse factor
// 1 - rL/l, negative under compression, is clamped at zero, which is the exact
// eigenvalue projection of this block).
SF_HD Sym3 patch_spring_hess(Vec3 xi, Vec3 xj, double L, double r, double Y, bool psd) {
  const Vec3 d = xi - xj;
  const double l = norm(d);
  const double k = Y / L;
  if (l < kSpringTinyLength) return sym3_identity(k);
  const Vec3 u = (1.0 / l) * d;
  double t = 1.0 - r * L / l;
  if (psd && t < 0) t = 0;
  // k [u u^T + t (I - u u^T)] = k t I + k (1 - t) u u^T
  return sym3_identity(k * t) + sym3_outer(u, k * (1.0 - t));
}

// Pattern-space derivative of lambda . f for one spring, where f = -dE/dx:
// returns d/dp_i of [-(g_i . lam_i + g_j . lam_j)]; d/dp_j is its negation.
// Only L depends on p (Y and r are constants).
SF_HD void patch_spring_dfdp_T(Vec3 xi, Vec3 xj, Vec3 lam_i, Vec3 lam_j, double pi_u, double pi_v,
                               double pj_u, double pj_v, double L, double r, double Y, double out[2]) {
  (void)r;
  const Vec3 d = xi - xj;
  const double l = norm(d);
  if (l < kSpringTinyLength) { out[0] = out[1] = 0; return; }
  // lam . f = -(Y/L)(l - rL) u.(lam_i - lam_j) = -(Y l / L - Y r) s ;  d/dL = Y l s / L^2
  const double s = dot(d, lam_i - lam_j) / l;
  const double dL = Y * l * s / (L * L);
  out[0] = dL * (pi_u - pj_u) / L;
  out[1] = dL * (pi_v - pj_v) / L;
}

SF_HD double sewing_spring_energy(Vec3 xi, Vec3 xj, double Ys) { return 0.5 * Ys * norm2(xi - xj); }
SF_HD Vec3 sewing_spring_grad(Vec3 xi, Vec3 xj, double Ys) { return Ys * (xi - xj); }
// Hessian block H_ii = Ys I (H_ij = -Ys I); exact and PSD.

}  // namespace seamfit::sim
