// Small host-device math for the simulator terms: symmetric 3x3 blocks and a
// forward-mode dual number used for pattern-space derivatives (d/dp of rest
// quantities that are awkward to differentiate by hand, e.g. cotangent weights).
#pragma once
#include <cmath>
#include "common/hd.hpp"
#include "common/vec3.hpp"

namespace seamfit::sim {

// Symmetric 3x3 matrix, stored as its 6 distinct entries.
struct Sym3 {
  double xx, yy, zz, xy, xz, yz;
};

SF_HD Sym3 sym3_zero() { return {0, 0, 0, 0, 0, 0}; }
SF_HD Sym3 sym3_identity(double s) { return {s, s, s, 0, 0, 0}; }
SF_HD Sym3 sym3_outer(Vec3 a, double s) {
  return {s * a.x * a.x, s * a.y * a.y, s * a.z * a.z, s * a.x * a.y, s * a.x * a.z, s * a.y * a.z};
}
SF_HD Sym3 operator+(Sym3 a, Sym3 b) {
  return {a.xx + b.xx, a.yy + b.yy, a.zz + b.zz, a.xy + b.xy, a.xz + b.xz, a.yz + b.yz};
}
SF_HD Sym3 operator*(double s, Sym3 a) {
  return {s * a.xx, s * a.yy, s * a.zz, s * a.xy, s * a.xz, s * a.yz};
}
SF_HD Sym3& operator+=(Sym3& a, Sym3 b) { a = a + b; return a; }
SF_HD Vec3 operator*(Sym3 m, Vec3 v) {
  return {m.xx * v.x + m.xy * v.y + m.xz * v.z, m.xy * v.x + m.yy * v.y + m.yz * v.z,
          m.xz * v.x + m.yz * v.y + m.zz * v.z};
}
SF_HD double sym3_get(const Sym3& m, int r, int c) {
  if (r == c) return r == 0 ? m.xx : (r == 1 ? m.yy : m.zz);
  const int s = r + c;  // 1: xy, 2: xz, 3: yz
  return s == 1 ? m.xy : (s == 2 ? m.xz : m.yz);
}

// Solve m * out = b for a symmetric positive definite m (Cholesky, 3x3). Returns
// false when m is not numerically positive definite.
SF_HD bool sym3_solve_spd(const Sym3& m, Vec3 b, Vec3& out) {
  const double l00sq = m.xx;
  if (!(l00sq > 0)) return false;
  const double l00 = sqrt(l00sq);
  const double l10 = m.xy / l00, l20 = m.xz / l00;
  const double l11sq = m.yy - l10 * l10;
  if (!(l11sq > 0)) return false;
  const double l11 = sqrt(l11sq);
  const double l21 = (m.yz - l20 * l10) / l11;
  const double l22sq = m.zz - l20 * l20 - l21 * l21;
  if (!(l22sq > 0)) return false;
  const double l22 = sqrt(l22sq);
  const double y0 = b.x / l00;
  const double y1 = (b.y - l10 * y0) / l11;
  const double y2 = (b.z - l20 * y0 - l21 * y1) / l22;
  out.z = y2 / l22;
  out.y = (y1 - l21 * out.z) / l11;
  out.x = (y0 - l10 * out.y - l20 * out.z) / l00;
  return true;
}

// Forward-mode dual number with N derivative slots.
template <int N>
struct Dual {
  double v;
  double d[N];
};

template <int N>
SF_HD Dual<N> dual_const(double v) {
  Dual<N> r;
  r.v = v;
  for (int i = 0; i < N; ++i) r.d[i] = 0;
  return r;
}
template <int N>
SF_HD Dual<N> dual_var(double v, int slot) {
  Dual<N> r = dual_const<N>(v);
  r.d[slot] = 1;
  return r;
}
template <int N>
SF_HD Dual<N> operator+(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] + b.d[i];
  return r;
}
template <int N>
SF_HD Dual<N> operator-(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] - b.d[i];
  return r;
}
template <int N>
SF_HD Dual<N> operator-(const Dual<N>& a) {
  Dual<N> r;
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.d[i] = -a.d[i];
  return r;
}
template <int N>
SF_HD Dual<N> operator*(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
template <int N>
SF_HD Dual<N> operator*(double s, const Dual<N>& a) {
  Dual<N> r;
  r.v = s * a.v;
  for (int i = 0; i < N; ++i) r.d[i] = s * a.d[i];
  return r;
}
template <int N>
SF_HD Dual<N> operator/(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v / b.v;
  const double inv = 1.0 / b.v;
  for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
  return r;
}
template <int N>
SF_HD Dual<N> dabs(const Dual<N>& a) { return a.v < 0 ? -a : a; }

// Constants of a templated scalar type (double or Dual<N>).
template <class T>
struct ConstOf {
  static SF_HD T make(double v) { return v; }
};
template <int N>
struct ConstOf<Dual<N>> {
  static SF_HD Dual<N> make(double v) { return dual_const<N>(v); }
};

// Scalar overloads so templated code runs on plain doubles too.
SF_HD double dabs(double a) { return fabs(a); }
SF_HD double value_of(double a) { return a; }
template <int N>
SF_HD double value_of(const Dual<N>& a) { return a.v; }

}  // namespace seamfit::sim
