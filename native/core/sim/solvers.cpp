// Quasistatic solvers.
//
// Chebyshev: gradient descent preconditioned by the per-vertex 3x3 blocks of
// the PSD Hessian (block Jacobi), accelerated by the Chebyshev semi-iterative
// method (Wang 2015; Wang and Yang 2016):
//     dx  = alpha D^{-1} f(x_k)
//     x_{k+1} = x_{k-1} + omega_{k+1} (x_k + dx - x_{k-1})
//     omega_1 = 1, omega_2 = 2 / (2 - rho^2), omega_{k+1} = 4 / (4 - rho^2 omega_k)
// The energy is checked every few iterations against a checkpoint; a rise
// restores the checkpoint and restarts the acceleration with a smaller rho
// (and, when rises repeat, a shorter step). The spectral radius is estimated
// from the plain Jacobi iterations after each (re)start (power iteration on the
// update) and then raised while the energy keeps falling.
//
// Newton: the PSD-projected Hessian factorized by sparse LDL^T (AMD ordering,
// pattern analysed once), a Levenberg shift when the factorization is not
// positive definite, a step bounded by the barrier, and Armijo backtracking.
// With an outside step solver (the GPU's MINRES) the same loop is an inexact
// Newton method: PSD Hessian, Eisenstat-Walker forcing terms.
#include <omp.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "sim/jacobi_step.hpp"
#include "sim/simulator.hpp"
#include "sim/solve_messages.hpp"

namespace seamfit::sim {

namespace {

using Clock = std::chrono::steady_clock;

// kProjectFloor, kFreeStep, kLipschitz and the safe step come from
// sim/jacobi_step.hpp, shared with the GPU.

// Inexact Newton (an outside step solver): the loosest forcing term, the least
// relative shift (the PSD Hessian is singular along free modes), and how often
// a step whose line search fails is solved again.
constexpr double kForcingMax = 0.1;
constexpr double kStepShift = 1e-8;
constexpr int kStepRetries = 3;

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Both solvers' convergence check: true (and the report says so) at the
// tolerance, which a NaN residual never reaches. `what` names the iterations.
bool reached_tolerance(SolveReport& rep, const SolveSettings& st, int it, double res, const char* what) {
  if (!(res <= st.tolerance)) return false;
  rep.converged = true;
  rep.message = msg_converged(res, st.tolerance, it, what);
  return true;
}

// The iteration and time budgets both solvers check each iteration: true (and
// the report's message) when one is spent. `what` names the iterations.
bool budget_spent(SolveReport& rep, const SolveSettings& st, int it, double res, Clock::time_point t0,
                  const char* what) {
  if (it >= st.max_iterations) {
    rep.message = msg_iteration_budget(res, st.tolerance, it, what);
    return true;
  }
  if (st.max_seconds > 0 && seconds_since(t0) > st.max_seconds) {
    rep.message = msg_time_budget(res, st.tolerance, seconds_since(t0));
    return true;
  }
  return false;
}

// Relative slack for energy comparisons: round-off of a sum of terms.
inline double energy_slack(const EnergyTerms& t) {
  return 1e-12 * (std::fabs(t.stretch) + std::fabs(t.sewing) + std::fabs(t.bending) + std::fabs(t.gravity) +
                  std::fabs(t.sticking) + std::fabs(t.barrier)) + 1e-300;
}

}  // namespace

SolveReport Simulator::solve_chebyshev(double* x, const SolveSettings& st, const ProgressFn& progress,
                                       const std::atomic<bool>* cancel) {
  const auto t0 = Clock::now();
  SolveReport rep;
  const int n3 = 3 * n_;
  const bool bar = barrier_on();
  if (bar) rep.projections += project_outside(x, kProjectFloor, projection_gap());

  std::vector<double> xc(x, x + n3), xp(xc), ck(xc), f(n3), d(n3);
  std::vector<Sym3> D(n_);
  std::vector<SdfSample> S(bar ? n_ : 0);
  EnergyTerms et;
  // known: S already holds the samples of xx (the update loop sampled them).
  // The springs' part of the preconditioner is refreshed every few iterations
  // (it changes slowly; computing it is a third of an iteration's cost).
  // Stale blocks can be too soft for a vertex whose springs have turned or
  // come out of compression since; its step then overshoots and comes back
  // (measured: a circle skirt's flare locked in an exact 4-cycle, period of
  // the refresh, every plain Jacobi step undone). So the economy holds only
  // while the iteration descends: an energy rise suspends it until 16 good
  // checkpoints in a row, like the step length (the rule is
  // reuse_spring_blocks in sim/jacobi_step.hpp, shared with the GPU).
  bool economy = true;
  int since_refresh = 0;
  auto eval = [&](std::vector<double>& xx, bool known) -> double {
    const bool reuse = reuse_spring_blocks(economy, known, since_refresh, st.precond_refresh);
    since_refresh = reuse ? since_refresh + 1 : 0;
    evaluate(xx.data(), f.data(), &et, D.data(), bar ? S.data() : nullptr, known && bar, reuse);
    return et.total();
  };

  double E = eval(xc, false), Eck = E;
  const double alpha0 = std::min(std::max(st.alpha, 1e-3), 1.0);
  double alpha = alpha0;
  const bool auto_rho = !(st.rho > 0);
  double rho = auto_rho ? 0.0 : std::min(st.rho, 0.99999);
  const int warmup = std::max(st.warmup, 2);
  const int check = std::max(st.check_every, 1);
  int k = 0;            // iterations since the last (re)start
  int rises = 0;        // consecutive energy rises
  int good_checks = 0;  // consecutive checkpoints with falling energy
  double omega = 1.0;
  std::vector<double> upd_norm;  // |dx| during warm-up, for the rho estimate
  // Beyond this phi (a margin past the barrier's reach) vertices skip the SDF.
  const double far = far_step_threshold(st.far_bound, params_.barrier_distance);

  int it = 0;
  for (;; ++it) {
    const double res = residual(f.data());
    rep.residual = res;
    if (st.history_every > 0 && it % st.history_every == 0) rep.record(it, seconds_since(t0), res);
    if (reached_tolerance(rep, st, it, res, "iterations")) break;
    if (!std::isfinite(res)) {
      // Never hand back a poisoned state: fall back to the last checkpoint.
      xc = ck;
      E = eval(xc, false);
      rep.residual = residual(f.data());
      rep.message = msg_non_finite(it);
      break;
    }
    if (budget_spent(rep, st, it, res, t0, "iterations")) break;
    if ((cancel && cancel->load()) ||
        (progress && st.progress_every > 0 && it % st.progress_every == 0 && !progress(it, res))) {
      rep.cancelled = true;
      rep.message = msg_cancelled(res, it, "iteration");
      break;
    }

    // Block-Jacobi step.
    double dn2 = 0;
#pragma omp parallel for reduction(+ : dn2) schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const Vec3 dv = jacobi_direction(D[v], {f[3 * v], f[3 * v + 1], f[3 * v + 2]}, alpha);
      d[3 * v] = dv.x;
      d[3 * v + 1] = dv.y;
      d[3 * v + 2] = dv.z;
      dn2 += norm2(dv);
    }
    if (k < warmup) {
      omega = 1.0;
      upd_norm.push_back(std::sqrt(dn2));
    } else if (k == warmup) {
      if (auto_rho) {
        // Power-iteration estimate from the second half of the warm-up.
        const int m = warmup / 2;
        const double a = upd_norm[warmup - 1 - m], b = upd_norm[warmup - 1];
        double est = (a > 0 && b > 0) ? std::pow(b / a, 1.0 / m) : 0.9;
        if (!std::isfinite(est)) est = 0.9;
        rho = std::max(rho, std::min(std::max(est, 0.5), 0.9995));
      }
      omega = 2.0 / (2.0 - rho * rho);
    } else {
      omega = 4.0 / (4.0 - rho * rho * omega);
    }
    // Chebyshev combination and the barrier-safe step (sim/jacobi_step.hpp).
    int rejected = 0;
    const bool smooth = params_.barrier_smooth;
#pragma omp parallel for reduction(+ : rejected) schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const Vec3 xo = {xc[3 * v], xc[3 * v + 1], xc[3 * v + 2]};
      const Vec3 mom = {xc[3 * v] - xp[3 * v], xc[3 * v + 1] - xp[3 * v + 1], xc[3 * v + 2] - xp[3 * v + 2]};
      Vec3 xn;
      SdfSample s = bar ? S[v] : SdfSample{};
      const int r = chebyshev_safe_step(xo, mom, {d[3 * v], d[3 * v + 1], d[3 * v + 2]}, omega, bar, sdf_, smooth,
                                        far, s, xn);
      if (bar) S[v] = s;
      if (r == kStepRejected) ++rejected;
      // x_{k-1} becomes x_k; a dropped step also drops the vertex's momentum.
      const Vec3 xk = r == kStepRejected ? xn : xo;
      xp[3 * v] = xk.x;
      xp[3 * v + 1] = xk.y;
      xp[3 * v + 2] = xk.z;
      xc[3 * v] = xn.x;
      xc[3 * v + 1] = xn.y;
      xc[3 * v + 2] = xn.z;
    }
    rep.rejected_steps += rejected;
    E = eval(xc, true);
    ++k;
    if (k % check == 0 || !std::isfinite(E)) {
      if (!(E <= Eck + energy_slack(et))) {
        // Energy rose: back to the checkpoint, restart the acceleration.
        ++rep.restarts;
        ++rises;
        xc = ck;
        xp = ck;
        E = eval(xc, false);
        k = 0;
        omega = 1.0;
        upd_norm.clear();
        if (auto_rho) rho = std::max(0.0, 1.0 - 2.0 * (1.0 - rho));
        else rho *= 0.9;
        if (rises >= 3) alpha = std::max(0.5 * alpha, 1e-3);
        economy = false;
        good_checks = 0;
      } else {
        ck = xc;
        Eck = E;
        rises = 0;
        // Still descending: widen the Chebyshev interval towards 1, and let a
        // step length cut by earlier rises grow back.
        if (auto_rho && k > warmup) rho = std::min(1.0 - 0.9 * (1.0 - rho), st.rho_max);
        if (++good_checks >= kRecoverChecks) {
          alpha = std::min(kAlphaRegrowth * alpha, alpha0);
          economy = true;
          good_checks = 0;
        }
      }
    }
  }
  rep.iterations = it;
  rep.energy = E;
  rep.final_rho = rho;
  rep.final_alpha = alpha;
  rep.seconds = seconds_since(t0);
  std::copy(xc.begin(), xc.end(), x);
  return rep;
}

double Simulator::jacobi_sweeps(double* x, int sweeps, double alpha) {
  const int n3 = 3 * n_;
  const bool bar = barrier_on();
  std::vector<double> f(n3), xn(n3);
  std::vector<Sym3> D(n_);
  std::vector<SdfSample> S(bar ? n_ : 0), Sn(bar ? n_ : 0);
  EnergyTerms et;
  evaluate(x, f.data(), &et, D.data(), bar ? S.data() : nullptr);
  double E = et.total();
  for (int k = 0; k < sweeps; ++k) {
#pragma omp parallel for schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const Vec3 dv = jacobi_direction(D[v], {f[3 * v], f[3 * v + 1], f[3 * v + 2]}, alpha);
      const Vec3 xo = {x[3 * v], x[3 * v + 1], x[3 * v + 2]};
      Vec3 xv = xo + dv;
      if (bar) barrier_safe_step(sdf_, params_.barrier_smooth, S[v], xo, dv, 0.0, xv, Sn[v]);
      xn[3 * v] = xv.x;
      xn[3 * v + 1] = xv.y;
      xn[3 * v + 2] = xv.z;
    }
    std::vector<double> fn(n3);
    std::vector<Sym3> Dn(n_);
    evaluate(xn.data(), fn.data(), &et, Dn.data(), bar ? Sn.data() : nullptr, bar);
    const double En = et.total();
    if (!(En <= E + energy_slack(et))) break;  // plain descent only
    std::copy(xn.begin(), xn.end(), x);
    f.swap(fn);
    D.swap(Dn);
    if (bar) S.swap(Sn);
    E = En;
  }
  return E;
}

SolveReport Simulator::solve_newton(double* x, const SolveSettings& st, const ProgressFn& progress,
                                    const std::atomic<bool>* cancel, const NewtonStepFn& step) {
  const auto t0 = Clock::now();
  SolveReport rep;
  const int n3 = 3 * n_;
  const bool bar = barrier_on();
  if (bar) rep.projections += project_outside(x, kProjectFloor, projection_gap());

  Eigen::Map<Eigen::VectorXd> X(x, n3);
  Eigen::VectorXd f(n3), dx(n3), xt(n3);
  EnergyTerms et;
  double E = force(x, f.data(), &et);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool analysed = false;
  bool exact_ok = true;     // the last exact-Hessian factorization was positive definite
  int last_exact_try = -1000;
  double shift = 0;  // Levenberg shift, relative to the mean diagonal
  // The line search lowers the energy, not the residual: on a nearly flat
  // energy (a free flare, folds) a run can end with more unbalanced force than
  // it started with. The state of least residual is kept and handed back.
  Eigen::VectorXd x_best = X;
  double res_best = std::numeric_limits<double>::infinity();
  // Outside step solver (inexact Newton): the forcing term, the residual
  // before the last step, and the retries of the current step.
  double forcing = kForcingMax, res_prev = -1;
  int retries = 0;
  bool step_exact = false;
  int it = 0;
  for (;; ++it) {
    const double res = residual(f.data());
    rep.residual = res;
    if (res < res_best) {
      res_best = res;
      x_best = X;
    }
    if (st.history_every > 0 && retries == 0) rep.record(it, seconds_since(t0), res);
    if (reached_tolerance(rep, st, it, res, "Newton iterations")) break;
    if (budget_spent(rep, st, it, res, t0, "Newton iterations")) break;
    if ((cancel && cancel->load()) || (progress && !progress(it, res))) {
      rep.cancelled = true;
      rep.message = msg_cancelled(res, it, "Newton iteration");
      break;
    }
    if (step) {
      // Eisenstat-Walker forcing (choice 2), capped at kForcingMax, never
      // tighter than reaching the tolerance needs, 100x tighter per retry.
      if (res_prev > 0 && retries == 0) {
        double eta = 0.9 * (res / res_prev) * (res / res_prev);
        if (0.9 * forcing * forcing > 0.1) eta = std::max(eta, 0.9 * forcing * forcing);
        forcing = std::min(eta, kForcingMax);
      }
      const double eta = std::max(forcing, 0.5 * st.tolerance / res) * std::pow(0.01, retries);
      // As with the factorization: the exact Hessian while its steps are
      // accepted, the PSD one after a failure (tried again every few iterations).
      step_exact = st.newton_exact_first && retries == 0 && (exact_ok || it - last_exact_try >= 8);
      if (step_exact) last_exact_try = it;
      const int k = step(x, !step_exact, std::max(shift, kStepShift), f.data(), eta, dx.data());
      if (k < 0) {
        rep.message = "not converged: the linear solve of the Newton step failed (relative residual " + fmt(res) + ")";
        break;
      }
      rep.linear_iterations += k;
    } else {
      // Exact Hessian when it is positive definite (quadratic convergence near a
      // strict minimum); otherwise the PSD-projected one with a Levenberg shift.
      // A failed attempt costs a whole factorization, so after a failure the
      // exact Hessian is tried again only every few iterations or close to
      // convergence.
      bool ok = false;
      const bool try_exact = st.newton_exact_first &&
                             (exact_ok || it - last_exact_try >= 8 || res < 20 * st.tolerance);
      if (try_exact) {
        last_exact_try = it;
        hessian(x, false);
        if (!analysed) {
          ldlt.analyzePattern(H_);
          analysed = true;
        }
        ldlt.factorize(H_);
        ok = ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0).all();
        exact_ok = ok;
      }
      if (!ok) {
        hessian(x, true);
        double mean_diag = 0;
        for (int c = 0; c < n3; ++c) mean_diag += H_.coeff(c, c);
        mean_diag = std::max(mean_diag / n3, 1e-300);
        if (!analysed) {
          ldlt.analyzePattern(H_);
          analysed = true;
        }
        Eigen::SparseMatrix<double> Hs;
        for (int tries = 0; tries < 12; ++tries) {
          const double delta = shift * mean_diag;
          if (delta > 0) {
            Hs = H_;
            for (int c = 0; c < n3; ++c) Hs.coeffRef(c, c) += delta;
            ldlt.factorize(Hs);
          } else {
            ldlt.factorize(H_);
          }
          ok = ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0).all();
          if (ok) break;
          shift = shift > 0 ? 10 * shift : 1e-10;
        }
      }
      if (!ok) {
        rep.message = "not converged: the stiffness matrix could not be factorized (relative residual " + fmt(res) + ")";
        break;
      }
      dx = ldlt.solve(f);
    }
    if (!dx.allFinite()) {
      rep.message = "not converged: the Newton step is not finite (relative residual " + fmt(res) + ")";
      break;
    }
    // Backtracking; the energy is +inf for any state with a vertex inside the
    // body, so accepted steps end outside. Against tunnelling through a thin
    // part of the body, no vertex moves further than its distance to the body
    // (the SDF is 1-Lipschitz) or kFreeStep, whichever is larger.
    // Per-vertex safeguards on each trial point (as in the Chebyshev loop): a
    // vertex closes at most half its gap along the SDF normal and moves no
    // further than its gap or kFreeStep. Without them a step that lowers the
    // total energy can park a vertex nanometres from the body, where its
    // barrier force (c/phi) swamps the residual for many iterations.
    std::vector<SdfSample> S0(bar ? n_ : 0);
    if (bar) {
#pragma omp parallel for schedule(static) num_threads(threads_)
      for (int v = 0; v < n_; ++v) S0[v] = sdf_at(make_vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2]));
    }
    auto trial = [&](double t) {
#pragma omp parallel for schedule(static) num_threads(threads_)
      for (int v = 0; v < n_; ++v) {
        const Vec3 xo = make_vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
        const Vec3 dv = make_vec3(t * dx[3 * v], t * dx[3 * v + 1], t * dx[3 * v + 2]);
        Vec3 xv = xo + dv;
        if (bar) {
          SdfSample sn;
          barrier_safe_step(sdf_, params_.barrier_smooth, S0[v], xo, dv, 0.0, xv, sn);
        }
        xt[3 * v] = xv.x;
        xt[3 * v + 1] = xv.y;
        xt[3 * v + 2] = xv.z;
      }
    };
    double t = 1.0;
    bool accepted = false;
    EnergyTerms et_t;
    // An inexact step that does not descend is solved again (below) rather
    // than searched down to a step that rounding lets pass.
    const int searches = step && !(f.dot(dx) > 0) ? 0 : 60;
    for (int ls = 0; ls < searches; ++ls) {
      trial(t);
      const double gain = f.dot(xt - X);  // first-order energy decrease of the actual move
      const double Et = energy(xt.data(), &et_t);
      if (gain > 0 && std::isfinite(Et) && Et <= E - 1e-4 * gain + energy_slack(et_t)) {
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (step) exact_ok = accepted || !step_exact;
    if (!accepted && step && retries < kStepRetries) {
      // An inexact step need not be a descent direction: solve it again,
      // tighter and more shifted (towards the preconditioned force).
      ++retries;
      shift = shift > 0 ? 10 * shift : 1e-6;
      --it;
      continue;
    }
    if (!accepted) {
      rep.message = "not converged: line search failed at relative residual " + fmt(res);
      break;
    }
    retries = 0;
    res_prev = res;
    const double tmax = 1.0;
    X = xt;
    E = force(x, f.data(), &et);
    if (st.newton_smoothing > 0) {
      // Block-Jacobi sweeps when a single vertex holds most of the residual: the
      // global line search moves a stiff local contact (a hem loaded onto a
      // toe) by tiny amounts, per-vertex steps settle it at once. Elsewhere
      // they would only perturb Newton's path.
      double tot = 0, top = 0;
      for (int v = 0; v < n_; ++v) {
        const double q = f[3 * v] * f[3 * v] + f[3 * v + 1] * f[3 * v + 1] + f[3 * v + 2] * f[3 * v + 2];
        tot += q;
        top = std::max(top, q);
      }
      if (top > 0.5 * tot) {
        jacobi_sweeps(x, st.newton_smoothing, st.alpha);
        E = force(x, f.data(), &et);
      }
    }
    shift = t >= 0.999 * tmax ? shift * 0.1 : shift;
    if (shift < 1e-12) shift = 0;
  }
  if (!rep.converged && !rep.cancelled && res_best < rep.residual) {
    X = x_best;
    E = force(x, f.data(), &et);
    rep.residual = residual(f.data());
    rep.message += "; returned the best state (relative residual " + fmt(rep.residual) + ")";
  }
  rep.iterations = it;
  rep.energy = E;
  rep.seconds = seconds_since(t0);
  return rep;
}

}  // namespace seamfit::sim
