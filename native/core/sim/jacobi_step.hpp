// The per-vertex rules of the Chebyshev-accelerated block-Jacobi iteration
// (solvers.cpp), host-device so the CPU solver and the CUDA backend take the
// same step: the block-Jacobi direction, the Chebyshev combination and the
// barrier-safe step against the body.
#pragma once
#include "body/sdf_grid.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"
#include "sim/terms/sdf_smooth.hpp"

namespace seamfit::sim {

// Vertices closer to the body than this (m) are projected out; anything above
// is a legitimate barrier state (pressed contact settles at tiny gaps).
constexpr double kProjectFloor = 1e-9;
// A vertex step may always be this long (m), thinner than any body part, so a
// bounded step cannot jump through the body between two outside states.
constexpr double kFreeStep = 0.005;
// A step may close at most this fraction of the gap along the SDF normal.
constexpr double kStepGapFraction = 0.5;
// Beyond the barrier's reach plus this margin (m), a step is bounded instead of
// sampled (see barrier_safe_step's far).
constexpr double kFarMargin = 0.002;

SF_HD double far_field_distance(double barrier_distance) { return barrier_distance + kFarMargin; }

// ---- Chebyshev control rules, shared by solvers.cpp and the CUDA control step
// (sim_iteration.cuh) so that both take the same decisions from SolveSettings.

// The `far` argument of barrier_safe_step for SolveSettings::far_bound: 0
// samples every step.
SF_HD double far_step_threshold(bool far_bound, double barrier_distance) {
  return far_bound ? far_field_distance(barrier_distance) : 0.0;
}

// Whether an evaluation takes the springs' share of the Jacobi blocks from the
// last refresh (SolveSettings::precond_refresh). known: the evaluation follows
// a step (its field samples came from the step), not a (re)start;
// since_refresh: evaluations since the last refresh; economy: off after an
// energy rise until kRecoverChecks good checkpoints in a row.
SF_HD bool reuse_spring_blocks(bool economy, bool known, int since_refresh, int precond_refresh) {
  const int every = precond_refresh > 1 ? precond_refresh : 1;
  return economy && known && since_refresh < every - 1;
}

// Consecutive checkpoints with falling energy after which the step length grows
// back by kAlphaRegrowth (up to its setting) and the economy resumes.
constexpr int kRecoverChecks = 16;
constexpr double kAlphaRegrowth = 1.25;

// std::max semantics (a NaN first argument is returned), usable in kernels.
SF_HD double step_max(double a, double b) { return a < b ? b : a; }

// The barrier's reading of the body: C2 B-spline or the grid's trilinear field.
SF_HD SdfSample barrier_field(const SdfGridView& g, bool smooth, Vec3 p) {
  if (smooth) {
    const SdfSample2 s = sdf_sample_smooth<false>(g, p);
    SdfSample r;
    r.phi = s.phi;
    r.grad = s.grad;
    return r;
  }
  return sdf_sample(g, p);
}

// Block-Jacobi direction alpha D^{-1} f; a block that is not numerically
// positive definite gets a small diagonal shift, and a vertex whose block is
// still singular does not move.
SF_HD Vec3 jacobi_direction(Sym3 D, Vec3 f, double alpha) {
  Vec3 d;
  if (!sym3_solve_spd(D, f, d)) {
    const double tr = fabs(D.xx) + fabs(D.yy) + fabs(D.zz);
    D += sym3_identity(1e-6 * tr + 1e-12);
    if (!sym3_solve_spd(D, f, d)) d = make_vec3(0, 0, 0);
  }
  return alpha * d;
}

// Verdicts of barrier_safe_step.
enum StepVerdict { kStepTaken = 0, kStepRejected = 1, kStepFar = 2 };

// Bound on |grad phi| of the barrier's field: a B-spline or trilinear reading of
// a distance grid has each derivative a mean of grid differences (<= 1 each),
// so |grad phi| <= sqrt(3); 1.8 leaves room for round-off in the grid.
constexpr double kLipschitz = 1.8;

// The barrier-safe step of one vertex from xo (field sample s there) along the
// proposed displacement dv; xn receives the position taken, sn the sample
// there. far > 0: a step that provably ends beyond phi = far (Lipschitz bound)
// is taken unsampled and sn carries the bound with a zero gradient (kStepFar).
//
// A vertex may close at most half its gap along the SDF normal, and never
// moves further than its gap or kFreeStep; a step that still lands too close
// (curved or creased body) slides back out to half the old gap, or is dropped
// (kStepRejected: xn = xo, sn = s).
SF_HD int barrier_safe_step(const SdfGridView& g, bool smooth, const SdfSample& s, Vec3 xo, Vec3 dv, double far,
                            Vec3& xn, SdfSample& sn) {
  const double gn = norm(s.grad);
  if (gn > 1e-12 && s.phi > 0) {
    const Vec3 nrm = (1.0 / gn) * s.grad;
    const double dn = dot(dv, nrm), lim = -kStepGapFraction * s.phi;
    if (dn < lim) dv -= (dn - lim) * nrm;
  }
  const double len = norm(dv), cap = step_max(0.9 * s.phi, kFreeStep);
  if (len > cap) dv = (cap / len) * dv;
  xn = xo + dv;
  // Far from the body: a Lipschitz lower bound of phi instead of a sample.
  const double bound = s.phi - kLipschitz * norm(dv);
  if (far > 0 && bound > far) {
    sn.phi = bound;
    sn.grad = make_vec3(0, 0, 0);
    return kStepFar;
  }
  sn = barrier_field(g, smooth, xn);
  // Sliding along the body: where the body curves away from the tangent plane
  // (or creases), a step can close more than half the gap although its normal
  // part may not; such a step is pushed back out along the field to its linear
  // prediction phi + grad.dv (at least half the old gap), a few Newton steps on
  // phi. Failing that the vertex stays. Steps that keep half the gap are left
  // alone (pure descent).
  const double want = step_max(s.phi + dot(s.grad, dv), 0.5 * s.phi);
  for (int h = 0; h < 3 && sn.phi < 0.5 * s.phi && sn.phi < want; ++h) {
    const double g2 = norm2(sn.grad);
    if (!(g2 > 1e-12)) break;
    xn += ((want - sn.phi) / g2) * sn.grad;
    sn = barrier_field(g, smooth, xn);
  }
  if (sn.phi < 0.25 * s.phi || !(sn.phi > kProjectFloor) || norm(xn - xo) > 2.0 * step_max(len, 1e-300)) {
    xn = xo;
    sn = s;
    return kStepRejected;
  }
  return kStepTaken;
}

// Chebyshev combination x_{k+1} = x_{k-1} + omega (x_k + d - x_{k-1}) written
// as a step from xo = x_k with momentum mom = x_k - x_{k-1}, then the
// barrier-safe step (bar: a body is present; far as in barrier_safe_step).
// s: the field sample at xo on entry, at the returned position xn on exit.
SF_HD int chebyshev_safe_step(Vec3 xo, Vec3 mom, Vec3 d, double omega, bool bar, const SdfGridView& g,
                              bool smooth, double far, SdfSample& s, Vec3& xn) {
  const Vec3 dv = omega * d + (omega - 1.0) * mom;
  if (!bar) {
    xn = xo + dv;
    return kStepTaken;
  }
  SdfSample sn;
  const int r = barrier_safe_step(g, smooth, s, xo, dv, far, xn, sn);
  s = sn;
  return r;
}

}  // namespace seamfit::sim
