// Distance cost, Eq. 11: C = k/2 * (phi(x_i) - phibar_i)^2 per garment vertex.
// phibar_i = phibar(xbar_i) is the base garment's signed distance to the base body,
// a constant; phi is the target body's SDF. The cost has no pattern dependence.
#pragma once
#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"

namespace seamfit {

// Value of one vertex's term; gx receives dC/dx_i.
SF_HD double distance_cost(const SdfGridView& sdf, Vec3 x, double phibar, double k, Vec3* gx) {
  const SdfSample s = sdf_sample(sdf, x);
  const double r = s.phi - phibar;
  *gx = (k * r) * s.grad;
  return 0.5 * k * r * r;
}

}  // namespace seamfit
