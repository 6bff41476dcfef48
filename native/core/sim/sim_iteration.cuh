// One iteration of the quasistatic simulator, vertex by vertex, for the CUDA
// backend. Everything here is host-device: the kernels in sim_gpu.cu are thin
// loops over these functions, and the same functions can be stepped on the
// host to check the control logic without a GPU.
//
// The energy terms are those of native/core/sim/terms (one implementation per
// term); the step is sim/jacobi_step.hpp; the control logic below mirrors
// Simulator::solve_chebyshev (solvers.cpp) rule for rule (the lagged spring
// blocks and bounded far steps included), kept on the device so that the host
// only looks in every few dozen iterations.
#pragma once
#include <cmath>
#include <cstdint>
#include <limits>

#include "body/sdf_grid.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/jacobi_step.hpp"
#include "sim/math.hpp"
#include "sim/terms/barrier.hpp"
#include "sim/terms/mass.hpp"
#include "sim/terms/spring.hpp"

namespace seamfit::cuda {

using sim::Sym3;

// The model on the device: topology (CSR gathers, no scatter), rest state and
// constants. R is the storage type of the rest state (double, or float where
// that is safe; arithmetic is always double).
template <class R>
struct DevModel {
  int n = 0;
  const int32_t* spring_v = nullptr;
  const int32_t *vs_ptr = nullptr, *vs_idx = nullptr;
  const int32_t *vw_ptr = nullptr, *vw_idx = nullptr;
  const int32_t *nbr_ptr = nullptr, *nbr_idx = nullptr, *self_slot = nullptr;
  const R *rest_L = nullptr, *shirring = nullptr, *Q = nullptr, *mass = nullptr, *barrier_c = nullptr;
  const double *stick_k = nullptr, *stick_t = nullptr;
  double Y = 0, Ys = 0, kb = 0, dhat = 0;
  Vec3 gv{0, 0, 0};
  int grav = 0, bar = 0, stick = 0, smooth = 0;
  SdfGridView sdf;
};

SF_HD Vec3 load3(const double* a, int i) { return make_vec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }
SF_HD void store3(double* a, int i, Vec3 v) {
  a[3 * i] = v.x;
  a[3 * i + 1] = v.y;
  a[3 * i + 2] = v.z;
}

// Energy terms in EnergyTerms order.
enum Term { kStretch = 0, kSewing, kBending, kGravity, kSticking, kBarrier, kTerms };

// One lane's share of vertex v when `lanes` threads work on it: the gradient
// g = dE/dx_v, the PSD diagonal block and the energy shares of incidences
// lane, lane + lanes, ... of each list (terms of pairs are split half and half
// between their two ends); lane 0 adds the per-vertex terms. The lanes' sums
// are the vertex's totals. With lanes = 1 this is Simulator::evaluate term for
// term and in the same order. s: the barrier field sample at x_v, read when
// known, written otherwise (lane 0).
// spring_blocks: compute the springs' Hessian blocks; Dsp receives this lane's
// springs' share of D. Otherwise (Simulator::evaluate's reuse_spring_diag)
// they are skipped and D starts from Dsp as given: the share stored at the last
// refresh on lane 0, zero on the others.
template <class R>
SF_HD void eval_vertex_part(const DevModel<R>& m, const double* x, int v, int lane, int lanes, bool known,
                            bool spring_blocks, SdfSample& s, Vec3& g, Sym3& Dsp, Sym3& D, double e[kTerms]) {
  const Vec3 xv = load3(x, v);
  g = make_vec3(0, 0, 0);
  D = spring_blocks ? sim::sym3_zero() : Dsp;
  for (int t = 0; t < kTerms; ++t) e[t] = 0;
  if (m.Y > 0) {
    for (int k = m.vs_ptr[v] + lane; k < m.vs_ptr[v + 1]; k += lanes) {
      const int code = m.vs_idx[k], sp = code >> 1;
      const Vec3 xi = load3(x, m.spring_v[2 * sp]), xj = load3(x, m.spring_v[2 * sp + 1]);
      const double L = double(m.rest_L[sp]), r = double(m.shirring[sp]);
      const Vec3 ge = sim::patch_spring_grad(xi, xj, L, r, m.Y);
      if (code & 1) g -= ge; else g += ge;
      if (spring_blocks) D += sim::patch_spring_hess(xi, xj, L, r, m.Y, true);
      e[kStretch] += 0.5 * sim::patch_spring_energy(xi, xj, L, r, m.Y);
    }
  }
  if (spring_blocks) Dsp = D;
  if (m.Ys > 0) {
    const int b = m.vw_ptr[v], en = m.vw_ptr[v + 1];
    for (int k = b + lane; k < en; k += lanes) {
      const Vec3 xu = load3(x, m.vw_idx[k]);
      g += sim::sewing_spring_grad(xv, xu, m.Ys);
      e[kSewing] += 0.5 * sim::sewing_spring_energy(xv, xu, m.Ys);
    }
    if (lane == 0) D += sim::sym3_identity(m.Ys * (en - b));
  }
  if (m.kb > 0) {
    const int b = m.nbr_ptr[v], en = m.nbr_ptr[v + 1];
    Vec3 qx = make_vec3(0, 0, 0);
    for (int k = b + lane; k < en; k += lanes) qx += double(m.Q[k]) * load3(x, m.nbr_idx[k]);
    g += m.kb * qx;
    e[kBending] += 0.5 * m.kb * dot(xv, qx);  // linear in qx: the lanes' shares add up
    if (lane == 0) D += sim::sym3_identity(m.kb * double(m.Q[b + m.self_slot[v]]));
  }
  if (lane != 0) return;
  if (m.grav) {
    const double mv = double(m.mass[v]);
    e[kGravity] += sim::gravity_energy(mv, m.gv, xv);
    g += sim::gravity_grad(mv, m.gv);
  }
  if (m.stick && m.stick_k[v] > 0) {
    const Vec3 t = load3(m.stick_t, v);
    e[kSticking] += sim::sticking_energy(m.stick_k[v], xv, t);
    g += sim::sticking_grad(m.stick_k[v], xv, t);
    D += sim::sym3_identity(m.stick_k[v]);
  }
  if (m.bar) {
    if (!known) s = sim::barrier_field(m.sdf, m.smooth != 0, xv);
    const double c = double(m.barrier_c[v]);
    if (s.phi > 0) {
      e[kBarrier] += sim::barrier_energy(c, m.dhat, s.phi);
      g += sim::barrier_grad(c, m.dhat, s);
      D += sim::barrier_hess_psd(c, m.dhat, s);
    } else {
      e[kBarrier] += std::numeric_limits<double>::infinity();
    }
  }
}

// Force f = -dE/dx at vertex v, its PSD diagonal block and its energy shares,
// by one thread.
template <class R>
SF_HD void eval_vertex(const DevModel<R>& m, const double* x, int v, bool known, SdfSample& s, Vec3& f, Sym3& D,
                       double e[kTerms]) {
  Vec3 g;
  Sym3 Dsp;
  eval_vertex_part(m, x, v, 0, 1, known, true, s, g, Dsp, D, e);
  f = -g;
}

// The Hessian's block of vertex v that does not couple it to other vertices
// (besides the springs' and the bending's share of the diagonal): the sewing
// springs' diagonal, sticking and the barrier, exact or PSD-projected.
template <class R>
SF_HD Sym3 own_hess_block(const DevModel<R>& m, const double* x, int v, bool psd) {
  Sym3 H = sim::sym3_zero();
  if (m.Ys > 0) H += sim::sym3_identity(m.Ys * (m.vw_ptr[v + 1] - m.vw_ptr[v]));
  if (m.stick && m.stick_k[v] > 0) H += sim::sym3_identity(m.stick_k[v]);
  if (m.bar) {
    const Vec3 xv = load3(x, v);
    const SdfSample s = sim::barrier_field(m.sdf, m.smooth != 0, xv);
    if (s.phi > 0) {
      const double c = double(m.barrier_c[v]);
      if (psd) {
        H += sim::barrier_hess_psd(c, m.dhat, s);
      } else {
        const Sym3 Hphi = m.smooth ? sim::sdf_sample_smooth<true>(m.sdf, xv).hess : sim::sdf_hessian(m.sdf, xv);
        H += sim::barrier_hess(c, m.dhat, s, Hphi);
      }
    }
  }
  return H;
}

// (d2E/dx2) vin at vertex v as a gather: own * vin_v, each incident spring's
// block spring_block(sp) times the difference of its ends (evaluated at both
// ends: no scatter), the sewing springs' couplings and the bending matrix Q.
// spring_block computes the block or loads a stored one (the GPU adjoint).
template <class R, class SpringBlock>
SF_HD Vec3 hess_vec_gather(const DevModel<R>& m, const double* vin, int v, const SpringBlock& spring_block,
                           const Sym3& own) {
  Vec3 r = own * load3(vin, v);
  if (m.Y > 0) {
    for (int k = m.vs_ptr[v]; k < m.vs_ptr[v + 1]; ++k) {
      const int code = m.vs_idx[k], sp = code >> 1, i = m.spring_v[2 * sp], j = m.spring_v[2 * sp + 1];
      const Vec3 ge = spring_block(sp) * (load3(vin, i) - load3(vin, j));
      if (code & 1) r -= ge; else r += ge;
    }
  }
  if (m.Ys > 0)
    for (int k = m.vw_ptr[v]; k < m.vw_ptr[v + 1]; ++k) r -= m.Ys * load3(vin, m.vw_idx[k]);
  if (m.kb > 0)
    for (int k = m.nbr_ptr[v]; k < m.nbr_ptr[v + 1]; ++k) r += (m.kb * double(m.Q[k])) * load3(vin, m.nbr_idx[k]);
  return r;
}

// The Hessian block of spring sp at x, exact or PSD-projected.
template <class R>
SF_HD Sym3 spring_hess_block(const DevModel<R>& m, const double* x, int sp, bool psd) {
  return sim::patch_spring_hess(load3(x, m.spring_v[2 * sp]), load3(x, m.spring_v[2 * sp + 1]),
                                double(m.rest_L[sp]), double(m.shirring[sp]), m.Y, psd);
}

// (d2E/dx2) vin at vertex v, exact or PSD-projected, by one thread: the
// product of Simulator::hess_vec term for term, every block computed here.
template <class R>
SF_HD Vec3 hess_vec_vertex(const DevModel<R>& m, const double* x, const double* vin, int v, bool psd) {
  return hess_vec_gather(
      m, vin, v, [&](int sp) { return spring_hess_block(m, x, sp, psd); }, own_hess_block(m, x, v, psd));
}

// ---------------------------------------------------------------------------
// Control state of one solve, on the device. The kernels of an iteration read
// mode / omega / alpha / save_ck from it; the control kernel updates it from
// the iteration's reductions.
enum Status { kRunning = 0, kConverged = 1, kNonFinite = 2, kBudget = 3 };
// kStep: take a step; kRestore: restore the checkpoint (energy rose) and
// evaluate it; kFinalRestore: the same, then stop (non-finite force);
// kInit: evaluate the start state.
enum Mode { kStep = 0, kRestore = 1, kFinalRestore = 2, kInit = 3 };

// Sums reduced over the vertices after each iteration.
enum Sum { kSumF2 = kTerms, kSumDn2, kSumRejected, kSums };

struct Ctrl {
  // Settings.
  double tol = 0, weight_norm = 1;
  int max_it = 0, warmup = 16, check = 8, history_every = 0, hist_cap = 0, auto_rho = 1;
  double rho_max = 0;  // the adapted rho's upper bound: SolveSettings::rho_max, set by the solve
  double alpha0 = 0.9;  // the step length the regrowth returns to (SolveSettings::alpha, clamped)
  // SolveSettings::precond_refresh (1 here: every evaluation refreshes and
  // nothing is stored, as time_kernels measures) and far_step_threshold.
  int precond_refresh = 1;
  double far = 0;
  // State.
  int it = 0, k = 0, rises = 0, done = 0, status = kRunning, mode = kInit, save_ck = 0, cur = 0;
  double E = 0, Eck = 0, rho = 0, alpha = 0.9, omega = 1, res = 0;
  // solve_chebyshev's economy, good_checks and since_refresh; reuse: the next
  // evaluation takes the springs' blocks stored at the last refresh.
  int economy = 1, good_checks = 0, since_refresh = 0, reuse = 0;
  double terms[kTerms] = {0, 0, 0, 0, 0, 0};
  int restarts = 0, hist_count = 0;
  long long rejected = 0;
  unsigned long long t0_ns = 0;  // device clock at the start state (history times)
};

// std::min semantics, and isfinite on either side.
SF_HD double ctrl_min(double a, double b) { return b < a ? b : a; }
SF_HD bool finite(double a) {
#ifdef __CUDA_ARCH__
  return isfinite(a);
#else
  return std::isfinite(a);
#endif
}

// The rules of ctrl_update below, less the preconditioner's bookkeeping.
SF_HD void ctrl_rules(Ctrl& c, const double sums[kSums], int new_cur, double* upd_norm, double* hist,
                      double now_s) {
  c.cur = new_cur;
  c.save_ck = 0;
  for (int t = 0; t < kTerms; ++t) c.terms[t] = sums[t];
  // EnergyTerms::total() order.
  const double E = sums[kStretch] + sums[kSewing] + sums[kBending] + sums[kGravity] + sums[kSticking] + sums[kBarrier];
  const double slack = 1e-12 * (fabs(sums[kStretch]) + fabs(sums[kSewing]) + fabs(sums[kBending]) +
                                fabs(sums[kGravity]) + fabs(sums[kSticking]) + fabs(sums[kBarrier])) + 1e-300;
  if (c.mode == kStep) {
    // The end of an iteration of solve_chebyshev: after the step and the
    // evaluation of the new state.
    if (c.k < c.warmup) upd_norm[c.k] = sqrt(sums[kSumDn2]);
    c.rejected += (long long)sums[kSumRejected];
    c.E = E;
    ++c.k;
    if (c.k % c.check == 0 || !finite(E)) {
      if (!(E <= c.Eck + slack)) {
        // Energy rose: back to the checkpoint (done by the next slot, which
        // then evaluates it), restart the acceleration.
        ++c.restarts;
        ++c.rises;
        c.mode = kRestore;
        c.k = 0;
        c.omega = 1.0;
        if (c.auto_rho) c.rho = sim::step_max(0.0, 1.0 - 2.0 * (1.0 - c.rho));
        else c.rho *= 0.9;
        if (c.rises >= 3) c.alpha = sim::step_max(0.5 * c.alpha, 1e-3);
        c.economy = 0;
        c.good_checks = 0;
        ++c.it;
        return;
      }
      c.save_ck = 1;  // the next slot copies the current state to the checkpoint
      c.Eck = E;
      c.rises = 0;
      if (c.auto_rho && c.k > c.warmup) c.rho = ctrl_min(1.0 - 0.9 * (1.0 - c.rho), c.rho_max);
      // Still descending: a step length cut by earlier rises grows back, and
      // the preconditioner's economy resumes.
      if (++c.good_checks >= sim::kRecoverChecks) {
        c.alpha = ctrl_min(sim::kAlphaRegrowth * c.alpha, c.alpha0);
        c.economy = 1;
        c.good_checks = 0;
      }
    }
    ++c.it;
  } else if (c.mode == kFinalRestore) {
    c.E = E;
    c.res = sqrt(sums[kSumF2]) / c.weight_norm;
    c.done = 1;
    return;
  } else {
    if (c.mode == kInit) c.Eck = E;
    c.E = E;
    c.mode = kStep;
  }
  // The top of the next iteration: residual, history, stopping rules.
  const double res = sqrt(sums[kSumF2]) / c.weight_norm;
  c.res = res;
  if (c.history_every > 0 && c.it % c.history_every == 0 && c.hist_count < c.hist_cap) {
    hist[3 * c.hist_count] = c.it;
    hist[3 * c.hist_count + 1] = now_s;
    hist[3 * c.hist_count + 2] = res;
    ++c.hist_count;
  }
  if (res <= c.tol) {
    c.status = kConverged;
    c.done = 1;
    return;
  }
  if (!finite(res)) {
    c.status = kNonFinite;
    c.mode = kFinalRestore;
    return;
  }
  if (c.it >= c.max_it) {
    c.status = kBudget;
    c.done = 1;
    return;
  }
  // Chebyshev weight of the coming step.
  if (c.k < c.warmup) {
    c.omega = 1.0;
  } else if (c.k == c.warmup) {
    if (c.auto_rho) {
      // Power-iteration estimate from the second half of the warm-up.
      const int m = c.warmup / 2;
      const double a = upd_norm[c.warmup - 1 - m], b = upd_norm[c.warmup - 1];
      double est = (a > 0 && b > 0) ? pow(b / a, 1.0 / m) : 0.9;
      if (!finite(est)) est = 0.9;
      c.rho = sim::step_max(c.rho, ctrl_min(sim::step_max(est, 0.5), 0.9995));
    }
    c.omega = 2.0 / (2.0 - c.rho * c.rho);
  } else {
    c.omega = 4.0 / (4.0 - c.rho * c.rho * c.omega);
  }
}

// Called once per iteration slot, after its evaluation, with the reduced sums;
// new_cur: the buffer that now holds the current positions. now_s: seconds
// since the solve began (for the residual history). Besides the rules, the
// preconditioner's bookkeeping of solve_chebyshev's eval: the evaluation just
// done refreshed the springs' blocks unless c.reuse, and the next one reuses
// them by the CPU's rule, where only an evaluation after a step (kStep) counts
// as known (restores and the start state refresh).
SF_HD void ctrl_update(Ctrl& c, const double sums[kSums], int new_cur, double* upd_norm, double* hist,
                       double now_s) {
  if (c.done) return;
  c.since_refresh = c.reuse ? c.since_refresh + 1 : 0;
  ctrl_rules(c, sums, new_cur, upd_norm, hist, now_s);
  c.reuse = !c.done && sim::reuse_spring_blocks(c.economy != 0, c.mode == kStep, c.since_refresh, c.precond_refresh);
}

}  // namespace seamfit::cuda
