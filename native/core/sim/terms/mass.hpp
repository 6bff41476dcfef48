// Lumped masses, gravity and sticking (pins, belts).
//
// m_i = rho * sum_{t ni i} A_t / 3 with A_t the pattern-space triangle area, so
// masses (and the gravity and barrier weights built on them) depend on p.
// Gravity: G = -sum_i m_i gvec . x_i.   Sticking: F = sum_i k_i / 2 |x_i - t_i|^2.
#pragma once
#include <cmath>
#include "common/hd.hpp"
#include "common/vec3.hpp"

namespace seamfit::sim {

// Pattern-space area of triangle (a, b, c) (absolute value; orientation-free).
SF_HD double tri_area_2d(const double a[2], const double b[2], const double c[2]) {
  return 0.5 * fabs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
}

// dA/d(a, b, c) into out[6].
SF_HD void tri_area_2d_grad(const double a[2], const double b[2], const double c[2], double out[6]) {
  const double cr = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  const double s = cr > 0 ? 0.5 : (cr < 0 ? -0.5 : 0.0);
  const double db0 = c[1] - a[1], db1 = -(c[0] - a[0]);
  const double dc0 = -(b[1] - a[1]), dc1 = b[0] - a[0];
  out[2] = s * db0; out[3] = s * db1;
  out[4] = s * dc0; out[5] = s * dc1;
  out[0] = -(out[2] + out[4]); out[1] = -(out[3] + out[5]);
}

SF_HD double gravity_energy(double m, Vec3 gvec, Vec3 x) { return -m * dot(gvec, x); }
SF_HD Vec3 gravity_grad(double m, Vec3 gvec) { return (-m) * gvec; }

SF_HD double sticking_energy(double k, Vec3 x, Vec3 target) { return 0.5 * k * norm2(x - target); }
SF_HD Vec3 sticking_grad(double k, Vec3 x, Vec3 target) { return k * (x - target); }
// Sticking Hessian: k I (exact, PSD).

}  // namespace seamfit::sim
