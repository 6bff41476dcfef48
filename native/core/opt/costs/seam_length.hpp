// Seam-length regularizer R^seam (an addition to Section 5.1; docs/optimizer.md).
//
// The sewn mesh pairs the two sides of a stitch vertex for vertex, so consecutive pairs
// (a0, b0), (a1, b1) give one matched segment per side. Per matched segment
//   r = |p_a1 - p_a0| - rho |p_b1 - p_b0|,     R = k/2 r^2,
// with rho the base ratio of the two segment lengths (1 on ordinary seams up to meshing
// round-off, the gathering ratio on gathered ones), so r = 0 on the base pattern and
// keeping every r at 0 keeps the sides' lengths, and the notches between, matched.
#pragma once
#include "opt/vec2.hpp"

namespace seamfit {

// d|e|/de; 0 for a collapsed segment (R stays continuous, the kink has no direction).
SF_HD Vec2 seam_unit(Vec2 e) {
  const double l = norm(e);
  return l > 0 ? (1.0 / l) * e : make_vec2(0, 0);
}

SF_HD double seam_residual(Vec2 pa0, Vec2 pa1, Vec2 pb0, Vec2 pb1, double rho) {
  return norm(pa1 - pa0) - rho * norm(pb1 - pb0);
}

// dr/d(p_a0, p_a1, p_b0, p_b1) as four 2-vectors (the Gauss-Newton Jacobian row).
SF_HD void seam_jacobian(Vec2 pa0, Vec2 pa1, Vec2 pb0, Vec2 pb1, double rho, Vec2 J[4]) {
  const Vec2 ua = seam_unit(pa1 - pa0), ub = seam_unit(pb1 - pb0);
  J[0] = -ua;
  J[1] = ua;
  J[2] = rho * ub;
  J[3] = -rho * ub;
}

// k = delta_seam. Value; gradients w.r.t. (p_a0, p_a1, p_b0, p_b1) into g.
SF_HD double seam_segment(Vec2 pa0, Vec2 pa1, Vec2 pb0, Vec2 pb1, double rho, double k, Vec2 g[4]) {
  const double r = seam_residual(pa0, pa1, pb0, pb1, rho);
  seam_jacobian(pa0, pa1, pb0, pb1, rho, g);
  for (int c = 0; c < 4; ++c) g[c] = (k * r) * g[c];
  return 0.5 * k * r * r;
}

// Matched segment s4 = (a0, a1, b0, b1) as theta indices: the per-element step of the CPU
// loop (opt::SeamLength::evaluate) and the GPU kernel (opt/regularizers_gpu.cu). Value;
// gradient slots into slot[0..3], gathered per theta entry in slot order (opt/costs/gather.hpp).
SF_HD double seam_element(const Vec2* theta, const int* s4, double rho, double k, Vec2* slot) {
  return seam_segment(theta[s4[0]], theta[s4[1]], theta[s4[2]], theta[s4[3]], rho, k, slot);
}

}  // namespace seamfit
