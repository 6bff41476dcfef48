// Distance cost, Eq. 11: C = k/2 * (phi(x_i) - phibar_i)^2 per garment vertex.
// phibar_i = phibar(xbar_i) is the base garment's signed distance to the base body,
// a constant; phi is the target body's SDF. The cost has no pattern dependence.
#pragma once
#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"
#include "opt/costs/term.hpp"

namespace seamfit {

// Value of one vertex's term; gx receives dC/dx_i.
SF_HD double distance_cost(const SdfGridView& sdf, Vec3 x, double phibar, double k, Vec3* gx) {
  const SdfSample s = sdf_sample(sdf, x);
  const double r = s.phi - phibar;
  *gx = (k * r) * s.grad;
  return 0.5 * k * r * r;
}

}  // namespace seamfit

namespace seamfit::opt::costs {

// C^dis over the vertices; the constant is phibar_i, supplied with the target SDF.
struct Distance {
  static constexpr Elements kOn = kVertices;
  static constexpr int kWidth = 1;
  static constexpr const char* kInput = "target SDF";
  static constexpr bool kField = true, kPattern = false;
  static SF_HD double element(const CostInputs& in, const int* v, const double* c, double k, Vec3* gx, Vec2*) {
    return distance_cost(in.sdf, in.x[v[0]], c[0], k, gx);
  }
};

}  // namespace seamfit::opt::costs
