// The matrix-free product (df/dp)^T lam of the adjoint gradient (paper §7:
// "we can avoid explicit evaluation of this matrix"), in the pieces the CPU
// (Simulator::dfdp_T) and the GPU (sim/dfdp_gpu.cu) both run: per spring
// (rest length), per hinge (bending), per vertex (mass weight of gravity and
// the barrier), per triangle (area), and a per-vertex gather of the element
// shares (no atomics, fixed order).
#pragma once
#include <cstdint>

#include "body/sdf_grid.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/terms/barrier.hpp"
#include "sim/terms/mass.hpp"

namespace seamfit::sim {

// d(lam . f)/dm_v: gravity, and the barrier whose weight is sb * m_v (above the
// mass floor; s is the barrier field at x_v).
SF_HD double dfdp_mass_weight(Vec3 gv, Vec3 lam_v, bool barrier, const SdfSample& s, double sb, double dhat) {
  double w = dot(gv, lam_v);
  // lam . f = -b'(phi) grad.lam with b' proportional to c = sb * m
  if (barrier && s.phi > 0) w -= sb * barrier_dphi(1.0, dhat, s.phi) * dot(s.grad, lam_v);
  return w;
}

// Triangle t's share: rho/3 (w_a + w_b + w_c) dA/d(p_a, p_b, p_c) into out[6].
SF_HD void dfdp_triangle(const double* p, const int32_t* tri, const double* w, double rho3, double out[6]) {
  const int a = tri[0], b = tri[1], c = tri[2];
  const double s = rho3 * (w[a] + w[b] + w[c]);
  double g[6];
  tri_area_2d_grad(p + 2 * a, p + 2 * b, p + 2 * c, g);
  for (int k = 0; k < 6; ++k) out[k] = s * g[k];
}

// Vertex v's (u, w) of (df/dp)^T lam: its springs (sign by side), hinges and
// triangles, from the element shares sp (2E), hp (8H) and tp (6T); a null
// array is a term that is off.
SF_HD void dfdp_gather(int v, const int32_t* vs_ptr, const int32_t* vs_idx, const double* sp,
                       const int32_t* vh_ptr, const int32_t* vh_idx, const double* hp,
                       const int32_t* vt_ptr, const int32_t* vt_idx, const double* tp, double out[2]) {
  double u = 0, w = 0;
  if (sp)
    for (int k = vs_ptr[v]; k < vs_ptr[v + 1]; ++k) {
      const int e = vs_idx[k] >> 1;
      const double sg = (vs_idx[k] & 1) ? -1.0 : 1.0;
      u += sg * sp[2 * e];
      w += sg * sp[2 * e + 1];
    }
  if (hp)
    for (int k = vh_ptr[v]; k < vh_ptr[v + 1]; ++k) {
      const int h = vh_idx[k] >> 2, s = vh_idx[k] & 3;
      u += hp[8 * h + 2 * s];
      w += hp[8 * h + 2 * s + 1];
    }
  if (tp)
    for (int k = vt_ptr[v]; k < vt_ptr[v + 1]; ++k) {
      const int t = vt_idx[k] / 3, s = vt_idx[k] % 3;
      u += tp[6 * t + 2 * s];
      w += tp[6 * t + 2 * s + 1];
    }
  out[0] = u;
  out[1] = w;
}

}  // namespace seamfit::sim
