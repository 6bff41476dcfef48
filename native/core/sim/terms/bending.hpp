// Quadratic bending (Bergou, Wardetzky, Harmon, Zorin, Grinspun 2006) with the
// flat pattern as rest state.
//
// Hinge h = (v0, v1, v2, v3): interior edge v0-v1, v2 opposite in triangle
// (v0, v1, v2), v3 opposite in triangle (v0, v1, v3). With interior angles
// a_k^t (at vertex k of triangle t) measured in the flat pattern,
//   K = [cot a1^0 + cot a1^1,  cot a0^0 + cot a0^1,  -(cot a0^0 + cot a1^0),  -(cot a0^1 + cot a1^1)]
//   w = 1 / (A0 + A1)
//   E_h = kb / 2 * w * |sum_k K_k x_k|^2
// K annihilates every affine map of the flat rest state, so the energy is zero
// at rest and invariant to rigid motions. Bergou's weight is 3 / (A0 + A1); on
// near-equilateral meshes that sum approximates 3 * integral of kappa^2 for an
// isometric (cylindrical) bend, so we use 1 / (A0 + A1) and kb is then the
// plate's flexural rigidity D (N m): E -> D/2 * integral kappa^2 dA.
// The Hessian kb w K K^T (x) I3 is constant and PSD.
#pragma once
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"

namespace seamfit::sim {

template <class T>
struct HingeStencil {
  T K[4];
  T w;
  bool valid;
};

// Sliver guard: a triangle whose area is below this fraction of its squared
// longest edge has unbounded cotangents; such hinges carry no bending.
constexpr double kHingeMinShape = 1e-6;

template <class T>
SF_HD void tri_cot_pair(const T pa[2], const T pb[2], const T pc[2], T& cot_a, T& cot_b, T& area,
                        double& shape) {
  // cot of the interior angles at a and b of triangle (a, b, c) in 2D.
  const T abu = pb[0] - pa[0], abv = pb[1] - pa[1];
  const T acu = pc[0] - pa[0], acv = pc[1] - pa[1];
  const T bcu = pc[0] - pb[0], bcv = pc[1] - pb[1];
  const T cr = dabs(abu * acv - abv * acu);  // 2 * area
  area = 0.5 * cr;
  cot_a = (abu * acu + abv * acv) / cr;
  // at b: vectors b->a = -ab and b->c = bc
  cot_b = (-(abu * bcu) - abv * bcv) / cr;
  const double lab = value_of(abu * abu + abv * abv), lac = value_of(acu * acu + acv * acv),
               lbc = value_of(bcu * bcu + bcv * bcv);
  double lmax = lab > lac ? lab : lac;
  lmax = lmax > lbc ? lmax : lbc;
  shape = lmax > 0 ? value_of(cr) / lmax : 0.0;
}

// Stencil from the four pattern positions p[0..3] (each 2 scalars, metres).
template <class T>
SF_HD HingeStencil<T> hinge_stencil(const T p0[2], const T p1[2], const T p2[2], const T p3[2]) {
  HingeStencil<T> s;
  T c0a, c1a, A0, c0b, c1b, A1;
  double sh0, sh1;
  tri_cot_pair(p0, p1, p2, c0a, c1a, A0, sh0);
  tri_cot_pair(p0, p1, p3, c0b, c1b, A1, sh1);
  s.valid = sh0 > kHingeMinShape && sh1 > kHingeMinShape;
  if (!s.valid) {
    for (int k = 0; k < 4; ++k) s.K[k] = ConstOf<T>::make(0.0);
    s.w = ConstOf<T>::make(0.0);
    return s;
  }
  s.K[0] = c1a + c1b;
  s.K[1] = c0a + c0b;
  s.K[2] = -(c0a + c1a);
  s.K[3] = -(c0b + c1b);
  s.w = ConstOf<T>::make(1.0) / (A0 + A1);
  return s;
}

// sum_k K_k x_k
SF_HD Vec3 hinge_curvature(const double K[4], Vec3 x0, Vec3 x1, Vec3 x2, Vec3 x3) {
  return K[0] * x0 + K[1] * x1 + K[2] * x2 + K[3] * x3;
}

SF_HD double hinge_energy(const double K[4], double w, double kb, Vec3 x0, Vec3 x1, Vec3 x2, Vec3 x3) {
  return 0.5 * kb * w * norm2(hinge_curvature(K, x0, x1, x2, x3));
}

// dE/dx_k = kb w K_k (K.x)
SF_HD void hinge_grad(const double K[4], double w, double kb, Vec3 x0, Vec3 x1, Vec3 x2, Vec3 x3,
                      Vec3 g[4]) {
  const Vec3 c = (kb * w) * hinge_curvature(K, x0, x1, x2, x3);
  for (int k = 0; k < 4; ++k) g[k] = K[k] * c;
}

// Pattern-space derivative of lambda . f for one hinge (f = -dE/dx):
// lambda . f = -kb w (K.x).(K.lambda); out[2k + a] = d/dp_k[a].
SF_HD void hinge_dfdp_T(const double p[8], const Vec3 x[4], const Vec3 lam[4], double kb, double out[8]) {
  typedef Dual<8> D;
  D q[4][2];
  for (int k = 0; k < 4; ++k)
    for (int a = 0; a < 2; ++a) q[k][a] = dual_var<8>(p[2 * k + a], 2 * k + a);
  const HingeStencil<D> s = hinge_stencil<D>(q[0], q[1], q[2], q[3]);
  if (!s.valid) {
    for (int i = 0; i < 8; ++i) out[i] = 0;
    return;
  }
  // (K.x).(K.lam) = sum_{k,l} K_k K_l (x_k . lam_l)
  D acc = dual_const<8>(0.0);
  for (int k = 0; k < 4; ++k)
    for (int l = 0; l < 4; ++l) acc = acc + dot(x[k], lam[l]) * (s.K[k] * s.K[l]);
  const D val = (-kb) * (s.w * acc);
  for (int i = 0; i < 8; ++i) out[i] = val.d[i];
}

}  // namespace seamfit::sim
