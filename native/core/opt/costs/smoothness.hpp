// Smoothness cost, Eq. 12-13, per interior hinge edge e = (i, j) with opposite
// vertices k (triangle i,j,k in mesh orientation) and l (triangle j,i,l):
//   C = kk/2 * (|L_e x| - s_e |L_e xbar|)^2,   L_e x = sum_a w_a x_a,
// with the four kernel weights w from the base pattern (isometric assumption, so
// they are constants; see hinge_kernel in opt/topology.hpp). s_e = +1 when the
// current and base hinges bend to the same side of their normals, -1 otherwise
// (Eq. 13); it is piecewise constant in x and is held fixed when differentiating.
// The base quantities enter as cbar = |L_e xbar| and sbar = sign(L_e xbar . nbar_e).
#pragma once
#include "common/vec3.hpp"
#include "opt/costs/term.hpp"
#include "opt/topology.hpp"

namespace seamfit {

SF_HD Vec3 hinge_apply(const double w[4], const Vec3 x[4]) {
  return w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
}

// Hinge normal n_e: the average of the two unit triangle normals (Eq. 13).
SF_HD Vec3 hinge_normal(const Vec3 x[4]) {
  const Vec3 n1 = cross(x[1] - x[0], x[2] - x[0]);
  const Vec3 n2 = cross(x[0] - x[1], x[3] - x[1]);
  const double l1 = norm(n1), l2 = norm(n2);
  Vec3 n = make_vec3(0, 0, 0);
  if (l1 > 0) n += (1.0 / l1) * n1;
  if (l2 > 0) n += (1.0 / l2) * n2;
  return n;
}

// Which side of its normal the hinge bends to: +1, -1, or 0 when exactly flat.
SF_HD double hinge_side(const double w[4], const Vec3 x[4]) {
  const double s = dot(hinge_apply(w, x), hinge_normal(x));
  return s > 0 ? 1.0 : (s < 0 ? -1.0 : 0.0);
}

SF_HD double smoothness_cost(const Vec3 x[4], const double w[4], double cbar, double sbar, double kk,
                             Vec3 g[4]) {
  const Vec3 lx = hinge_apply(w, x);
  const double m = norm(lx);
  // A flat side carries no convexity information: compare magnitudes only (s = +1).
  const double side = hinge_side(w, x) * sbar;
  const double s = side < 0 ? -1.0 : 1.0;
  const double r = m - s * cbar;
  // d|Lx|/dx_a = w_a Lx/|Lx|; at |Lx| = 0 the zero vector is a valid subgradient.
  const Vec3 dir = m > 0 ? (kk * r / m) * lx : make_vec3(0, 0, 0);
  for (int a = 0; a < 4; ++a) g[a] = w[a] * dir;
  return 0.5 * kk * r * r;
}

}  // namespace seamfit

namespace seamfit::opt::costs {

// C^smo over the interior hinges; the constants are the kernel weights w (4), cbar and sbar.
struct Smoothness {
  static constexpr Elements kOn = kHinges;
  static constexpr int kWidth = 6;
  static constexpr const char* kInput = nullptr;
  static constexpr bool kField = false, kPattern = false;
  static void base(const BaseGarment& b, const int* v, double* c) {
    const std::array<double, 4> w = hinge_kernel({v[0], v[1], v[2], v[3]}, b.pbar);
    const Vec3 xb[4] = {b.xbar[v[0]], b.xbar[v[1]], b.xbar[v[2]], b.xbar[v[3]]};
    for (int a = 0; a < 4; ++a) c[a] = w[a];
    c[4] = norm(hinge_apply(w.data(), xb));
    c[5] = hinge_side(w.data(), xb);
  }
  static SF_HD double element(const CostInputs& in, const int* v, const double* c, double k, Vec3* gx, Vec2*) {
    const Vec3 xs[4] = {in.x[v[0]], in.x[v[1]], in.x[v[2]], in.x[v[3]]};
    return smoothness_cost(xs, c, c[4], c[5], k, gx);
  }
};

}  // namespace seamfit::opt::costs
