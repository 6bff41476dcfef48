// The rest state of the cloth from its pattern p, element by element: rest
// lengths, pattern-space masses, barrier weights and the bending matrix Q on
// the block pattern. Host-device, so the CPU simulator (Simulator::
// update_rest_state) and the GPU (sim_gpu.cu, after a pattern update on the
// device) compute it with the same arithmetic.
#pragma once
#include <cmath>
#include <cstdint>

#include "common/hd.hpp"
#include "sim/terms/bending.hpp"
#include "sim/terms/mass.hpp"

namespace seamfit::sim {

// Rest length of spring (i, j); lengths below L_floor are floored there and
// flagged (a floored length has no p-derivative).
SF_HD double spring_rest_length(const double* p, int i, int j, double L_floor, uint8_t* floored) {
  const double L = hypot(p[2 * i] - p[2 * j], p[2 * i + 1] - p[2 * j + 1]);
  *floored = L < L_floor ? 1 : 0;
  return L < L_floor ? L_floor : L;
}

SF_HD double triangle_rest_area(const double* p, const int32_t* tri) {
  return tri_area_2d(p + 2 * tri[0], p + 2 * tri[1], p + 2 * tri[2]);
}

// Lumped mass rho sum_t A_t / 3 over the triangles at v (incidence t*3 + k).
SF_HD double vertex_mass(int v, const int32_t* vt_ptr, const int32_t* vt_idx, const double* tri_area, double density) {
  double a = 0;
  for (int k = vt_ptr[v]; k < vt_ptr[v + 1]; ++k) a += tri_area[vt_idx[k] / 3];
  return density * a / 3.0;
}

// Per-vertex barrier weight: scale * m, with tiny masses raised to m_floor.
SF_HD double barrier_weight(double mass, double m_floor, double scale) {
  return scale * (mass > m_floor ? mass : m_floor);
}

// Hinge h's stencil K (4) and weight w from the pattern.
SF_HD void hinge_rest(const double* p, const int32_t* hv, double K[4], double* w) {
  const HingeStencil<double> s = hinge_stencil<double>(p + 2 * hv[0], p + 2 * hv[1], p + 2 * hv[2], p + 2 * hv[3]);
  for (int k = 0; k < 4; ++k) K[k] = s.K[k];
  *w = s.w;
}

// Position of u in v's sorted neighbour list, or -1.
SF_HD int neighbour_slot(const int32_t* nbr_ptr, const int32_t* nbr_idx, int v, int u) {
  int lo = nbr_ptr[v], hi = nbr_ptr[v + 1];
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (nbr_idx[mid] < u) lo = mid + 1;
    else hi = mid;
  }
  return lo < nbr_ptr[v + 1] && nbr_idx[lo] == u ? lo - nbr_ptr[v] : -1;
}

// Row v of Q = sum_h w_h K_h K_h^T on the block pattern (row: the slots of v's
// neighbours, zeroed here), from the hinges at v (incidence h*4 + k).
SF_HD void bending_q_row(int v, const int32_t* vh_ptr, const int32_t* vh_idx, const int32_t* hinge_v,
                         const double* hinge_K, const double* hinge_w, const int32_t* nbr_ptr, const int32_t* nbr_idx,
                         double* row) {
  for (int s = 0; s < nbr_ptr[v + 1] - nbr_ptr[v]; ++s) row[s] = 0;
  for (int q = vh_ptr[v]; q < vh_ptr[v + 1]; ++q) {
    const int h = vh_idx[q] >> 2, k = vh_idx[q] & 3;
    const double w = hinge_w[h];
    if (w == 0) continue;
    for (int l = 0; l < 4; ++l)
      row[neighbour_slot(nbr_ptr, nbr_idx, v, hinge_v[4 * h + l])] += w * hinge_K[4 * h + k] * hinge_K[4 * h + l];
  }
}

}  // namespace seamfit::sim
