// Log barrier against the body's signed distance field (Wang 2018, Eq. 4):
//   B_i = -c_i log(phi(x_i)) near the body,   c_i = mu * l_b * g * m_i.
// The paper's constant mu (0.01, unitless there) is rescaled per vertex by the
// vertex weight m_i g times a length l_b, so mu is dimensionless and a vertex
// resting on the body under its own weight settles at phi = mu * l_b (1 mm for
// mu = 0.01 and l_b = 0.1 m). The barrier is undefined for phi <= 0; the
// solvers project such vertices back outside before evaluating it.
#pragma once
#include <cstdint>
#include "body/sdf_grid.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"

namespace seamfit::sim {

// Hessian of the trilinear interpolant used by sdf_sample (consistent with its
// value and gradient, including the distance-to-box continuation outside the
// grid). Pure second derivatives vanish inside a cell; mixed ones do not.
SF_HD Sym3 sdf_hessian(const SdfGridView& g, Vec3 p) {
  const double h = g.spacing;
  const SdfCell cell = sdf_cell(g, p);
  const double* t = cell.t;
  const double* outside = cell.outside;
  const bool* clamped = cell.clamped;
  auto at = [&](int i, int j, int k) -> double {
    return sdf_node(g, cell.base[0] + i, cell.base[1] + j, cell.base[2] + k);
  };
  double c[2][2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) c[i][j][k] = at(i, j, k);
  const double tx = t[0], ty = t[1], tz = t[2];
  // d2/dx dy = sum c_ijk w'_i w'_j w_k(tz) / h^2, with w'_0 = -1, w'_1 = +1
  double dxy = 0, dxz = 0, dyz = 0;
  for (int k = 0; k < 2; ++k) {
    const double wz = k ? tz : 1 - tz;
    dxy += wz * (c[1][1][k] - c[0][1][k] - c[1][0][k] + c[0][0][k]);
  }
  for (int j = 0; j < 2; ++j) {
    const double wy = j ? ty : 1 - ty;
    dxz += wy * (c[1][j][1] - c[0][j][1] - c[1][j][0] + c[0][j][0]);
  }
  for (int i = 0; i < 2; ++i) {
    const double wx = i ? tx : 1 - tx;
    dyz += wx * (c[i][1][1] - c[i][0][1] - c[i][1][0] + c[i][0][0]);
  }
  const double ih2 = 1.0 / (h * h);
  Sym3 H = {0, 0, 0, dxy * ih2, dxz * ih2, dyz * ih2};
  // The interpolant does not depend on clamped coordinates.
  if (clamped[0] || clamped[1]) H.xy = 0;
  if (clamped[0] || clamped[2]) H.xz = 0;
  if (clamped[1] || clamped[2]) H.yz = 0;
  const double od2 = outside[0] * outside[0] + outside[1] * outside[1] + outside[2] * outside[2];
  if (od2 > 0) {
    // Hessian of the distance to the box, (I - o o^T / |o|^2) / |o| on clamped axes.
    const double od = sqrt(od2);
    double m[3][3];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        m[a][b] = (clamped[a] && clamped[b]) ? ((a == b ? 1.0 : 0.0) - outside[a] * outside[b] / od2) / od : 0.0;
    H.xx += m[0][0]; H.yy += m[1][1]; H.zz += m[2][2];
    H.xy += m[0][1]; H.xz += m[0][2]; H.yz += m[1][2];
  }
  return H;
}

// Energy, gradient and Hessian of the barrier at one vertex, given the SDF
// sample. With s = phi / d (d: activation distance)
//   b(phi) = c * (-log s + (s - 1) - (s - 1)^2 / 2)   for s < 1, else 0,
// i.e. the paper's -c log(phi) plus the quadratic Taylor polynomial that makes
// b, b' and b'' vanish at phi = d. Near the body (phi << d) force and
// stiffness are those of -c log(phi): b' = -c (1 - s)^2 / phi, b'' = c/phi^2 - c/d^2.
// Beyond d the barrier is zero, so it neither pushes far-away cloth nor lets
// the energy fall without bound (-log phi -> -inf as phi -> inf).
// The PSD variant keeps b'' grad grad^T (b'' >= 0) and drops the curvature
// term b' Hphi, which can be indefinite.
SF_HD double barrier_energy(double c, double d, double phi) {
  if (phi >= d) return 0.0;
  const double s = phi / d, t = s - 1.0;
  return c * (-log(s) + t - 0.5 * t * t);
}
SF_HD double barrier_dphi(double c, double d, double phi) {
  if (phi >= d) return 0.0;
  const double t = 1.0 - phi / d;
  return -c * t * t / phi;
}
SF_HD double barrier_d2phi(double c, double d, double phi) {
  if (phi >= d) return 0.0;
  return c / (phi * phi) - c / (d * d);
}
SF_HD Vec3 barrier_grad(double c, double d, const SdfSample& s) { return barrier_dphi(c, d, s.phi) * s.grad; }
SF_HD Sym3 barrier_hess_psd(double c, double d, const SdfSample& s) {
  return sym3_outer(s.grad, barrier_d2phi(c, d, s.phi));
}
SF_HD Sym3 barrier_hess(double c, double d, const SdfSample& s, const Sym3& sdf_H) {
  return sym3_outer(s.grad, barrier_d2phi(c, d, s.phi)) + barrier_dphi(c, d, s.phi) * sdf_H;
}

}  // namespace seamfit::sim
