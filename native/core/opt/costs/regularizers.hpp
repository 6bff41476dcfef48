// Pattern regularizers on the boundary vertices (Section 5.1).
//
// Fixing, Eq. 9: R = k/2 |p_i - pbar_i|^2 per boundary vertex.
//
// Curve shape, Eq. 10: R = k w_i/2 |p_j + p_k - 2 p_i - T_i (pbar_j + pbar_k - 2 pbar_i)|^2
// per boundary vertex i with outline neighbours j (previous) and k (next). T_i is the
// rotation-and-uniform-scale that maps the base chord pbar_k - pbar_j onto the current
// chord p_k - p_j (the local boundary frame). Writing 2-vectors as complex numbers,
// T_i dbar_i = (c_i / cbar_i) dbar_i = z_i c_i with the constant z_i = dbar_i / cbar_i, so
// the residual is linear in p, R^cur is an exact quadratic and its Hessian is constant.
// (The similarity that best maps dbar_i onto d_i itself would always fit exactly, since
// a 2D similarity has two degrees of freedom, and make R^cur vanish identically.)
#pragma once
#include "opt/costs/gather.hpp"
#include "opt/vec2.hpp"

namespace seamfit {

SF_HD double fix_regularizer(Vec2 p, Vec2 pbar, double k, Vec2* g) {
  const Vec2 d = p - pbar;
  *g = k * d;
  return 0.5 * k * norm2(d);
}

// Residual of the curve term: d_i - z_i c_i.
SF_HD Vec2 curve_residual(Vec2 pj, Vec2 pi, Vec2 pk, Vec2 z) {
  return pj + pk - 2.0 * pi - cmul(z, pk - pj);
}

// z_i = dbar_i / cbar_i from the base pattern (0 for a degenerate chord).
SF_HD Vec2 curve_frame(Vec2 pbj, Vec2 pbi, Vec2 pbk) {
  const Vec2 c = pbk - pbj;
  if (norm2(c) == 0) return make_vec2(0, 0);
  return cdiv(pbj + pbk - 2.0 * pbi, c);
}

// kw = delta_cur * w_i.
SF_HD double curve_regularizer(Vec2 pj, Vec2 pi, Vec2 pk, Vec2 z, double kw, Vec2* gj, Vec2* gi, Vec2* gk) {
  const Vec2 r = curve_residual(pj, pi, pk, z);
  const Vec2 gr = kw * r;
  const Vec2 zg = cmul_t(z, gr);  // (dr/dp_k)^T = I - Z^T, (dr/dp_j)^T = I + Z^T
  *gj = gr + zg;
  *gi = -2.0 * gr;
  *gk = gr - zg;
  return 0.5 * kw * norm2(r);
}

// The per-element and per-entry steps of R^fix + R^cur over theta, shared by the CPU loop
// (opt::Regularizers::evaluate) and the GPU kernels (opt/regularizers_gpu.cu): each curve
// element writes its value and three gradient slots, then each theta entry gathers its
// slots in slot order (no atomics, the sum order of a scatter in element order).

// Curve element jik = (j, i, k): value; gradient slots (j, i, k) into slot[0..2].
SF_HD double curve_element(const Vec2* theta, const int* jik, Vec2 z, double kw, Vec2* slot) {
  return curve_regularizer(theta[jik[0]], theta[jik[1]], theta[jik[2]], z, kw, &slot[0], &slot[1], &slot[2]);
}

// Gradient of R at theta entry b: R^fix's term, then (cur_on) the curve slots touching b
// (gather table offsets / slots). R^fix at b into *vfix (0 when fix is 0).
SF_HD Vec2 regularizer_gradient_at(int b, const Vec2* theta, const Vec2* theta_bar, double fix, bool cur_on,
                                   const int* offsets, const int* slots, const Vec2* slot_vals, double* vfix) {
  Vec2 g = make_vec2(0, 0);
  *vfix = 0;
  if (fix != 0) *vfix = fix_regularizer(theta[b], theta_bar[b], fix, &g);
  if (cur_on) gather_add(b, offsets, slots, slot_vals, g);
  return g;
}

}  // namespace seamfit
