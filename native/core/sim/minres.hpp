// The scalar recurrences of preconditioned MINRES (Paige and Saunders 1975) for
// the adjoint system H lam = g, host-device: the GPU adjoint (sim/adjoint_gpu.cu)
// runs them in a one-thread step between its vector kernels,
// and they can be stepped on the host against a reference.
//
// Why MINRES: the exact tangent stiffness H is symmetric but may be indefinite
// away from a strict minimum (compressed springs, the barrier's curvature
// term), which rules out CG; MINRES needs only symmetry, and its
// preconditioner only positive definiteness (the PSD diagonal blocks).
//
// One iteration, with y = M^-1 r2 from the previous one and v = y / beta:
//   t = H v - (beta / oldb) r1;  alfa = v.t;  t -= (alfa / beta) r2
//   r1 = r2;  r2 = t;  y = M^-1 r2;  beta' = sqrt(r2.y)     (vector kernels)
//   minres_rotate(s, alfa, beta')                            (this file)
//   w' = (v - oldeps w2 - delta w) denom;  w2 = w;  w = w';  lam += phi w'
// phibar is the M^-1-norm of the residual of lam in exact arithmetic.
#pragma once
#include <cmath>

#include "common/hd.hpp"

namespace seamfit::sim {

enum MinresStatus { kMinresRunning = 0, kMinresConverged = 1, kMinresBudget = 2, kMinresBreakdown = 3 };

// The name reports use for a final status.
inline const char* minres_status_name(int status) {
  return status == kMinresConverged ? "converged" : status == kMinresBudget ? "budget" : "breakdown";
}

struct MinresState {
  // Settings.
  double tol = 1e-6;      // stop at phibar <= tol * bnorm
  int max_it = 10000;
  // Recurrence.
  double beta = 0, oldb = 0, alfa = 0, dbar = 0, epsln = 0, oldeps = 0, phibar = 0, cs = -1, sn = 0;
  double phi = 0, delta = 0, denom = 0;
  double beta1 = 0;       // residual norm of the start
  double bnorm = 0;       // |g|_{M^-1}: the reference of the stopping test
  double shift = 0;       // the Tikhonov shift added to H's diagonal
  double gnorm2 = 0, rnorm2 = 0;  // |g|^2 and the true |g - H lam|^2 (at the end)
  int it = 0, done = 0, status = kMinresRunning, pending = 0;
};

// The start: beta1 = |r0|_{M^-1} with r0 = g - H lam0, bnorm = |g|_{M^-1}.
SF_HD void minres_start(MinresState& s, double r_dot_y, double g_dot_mg) {
  s.it = 0;
  s.pending = 0;
  s.done = 0;
  s.status = kMinresRunning;
  if (!(r_dot_y >= 0) || !(g_dot_mg >= 0)) {  // negative or NaN: M is not positive definite
    s.status = kMinresBreakdown;
    s.done = 1;
    return;
  }
  s.beta1 = sqrt(r_dot_y);
  s.bnorm = sqrt(g_dot_mg);
  s.beta = s.beta1;
  s.oldb = 0;
  s.dbar = 0;
  s.epsln = 0;
  s.phibar = s.beta1;
  s.cs = -1;
  s.sn = 0;
  if (s.beta1 <= s.tol * s.bnorm) {
    s.status = kMinresConverged;
    s.done = 1;
  }
}

// After the vector kernels of an iteration: r2_dot_y = r2.(M^-1 r2) of the new
// Lanczos vector. Sets phi, delta, oldeps and denom for the lam update, which
// is then pending.
SF_HD void minres_rotate(MinresState& s, double r2_dot_y) {
  if (!(r2_dot_y >= 0)) {
    s.status = kMinresBreakdown;
    s.done = 1;
    return;
  }
  s.oldb = s.beta;
  s.beta = sqrt(r2_dot_y);
  s.oldeps = s.epsln;
  s.delta = s.cs * s.dbar + s.sn * s.alfa;
  const double gbar = s.sn * s.dbar - s.cs * s.alfa;
  s.epsln = s.sn * s.beta;
  s.dbar = -s.cs * s.beta;
  double gamma = sqrt(gbar * gbar + s.beta * s.beta);
  if (!(gamma > 1e-300)) gamma = 1e-300;
  s.cs = gbar / gamma;
  s.sn = s.beta / gamma;
  s.phi = s.cs * s.phibar;
  s.phibar = s.sn * s.phibar;
  s.denom = 1.0 / gamma;
  s.pending = 1;
  ++s.it;
  if (!(s.phibar <= 1e300)) {  // NaN or overflow
    s.status = kMinresBreakdown;
    s.done = 1;
  } else if (s.phibar <= s.tol * s.bnorm || s.beta <= 1e-300) {
    // beta = 0: the Krylov space is invariant, lam after this update is exact.
    s.status = kMinresConverged;
    s.done = 1;
  } else if (s.it >= s.max_it) {
    s.status = kMinresBudget;
    s.done = 1;
  }
}

}  // namespace seamfit::sim
