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
#include <omp.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "sim/simulator.hpp"

namespace seamfit::sim {

namespace {

using Clock = std::chrono::steady_clock;

// Vertices closer to the body than this (m) are projected out; anything above
// is a legitimate barrier state (pressed contact settles at tiny gaps).
constexpr double kProjectFloor = 1e-9;
// A vertex step may always be this long (m), thinner than any body part, so a
// bounded step cannot jump through the body between two outside states.
constexpr double kFreeStep = 0.005;

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
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
  const bool bar = has_sdf_ && params_.mu > 0;
  const double gap = projection_gap();
  if (bar) rep.projections += project_outside(x, kProjectFloor, gap);

  std::vector<double> xc(x, x + n3), xp(xc), ck(xc), f(n3), d(n3);
  std::vector<Sym3> D(n_);
  std::vector<SdfSample> S(bar ? n_ : 0);
  EnergyTerms et;
  // known: S already holds the samples of xx (the update loop sampled them).
  auto eval = [&](std::vector<double>& xx, bool known) -> double {
    evaluate(xx.data(), f.data(), &et, D.data(), bar ? S.data() : nullptr, known && bar);
    return et.total();
  };

  double E = eval(xc, false), Eck = E;
  double alpha = std::min(std::max(st.alpha, 1e-3), 1.0);
  const bool auto_rho = !(st.rho > 0);
  double rho = auto_rho ? 0.0 : std::min(st.rho, 0.99999);
  const int warmup = std::max(st.warmup, 2);
  const int check = std::max(st.check_every, 1);
  int k = 0;            // iterations since the last (re)start
  int rises = 0;        // consecutive energy rises
  double omega = 1.0;
  std::vector<double> upd_norm;  // |dx| during warm-up, for the rho estimate
  const double beta = 0.5;       // a step may close at most this fraction of the gap

  int it = 0;
  for (;; ++it) {
    const double res = residual(f.data());
    rep.residual = res;
    if (st.history_every > 0 && it % st.history_every == 0) {
      rep.hist_iter.push_back(it);
      rep.hist_seconds.push_back(seconds_since(t0));
      rep.hist_residual.push_back(res);
    }
    if (res <= st.tolerance) {
      rep.converged = true;
      rep.message = "converged: relative residual " + fmt(res) + " <= " + fmt(st.tolerance) + " after " +
                    std::to_string(it) + " iterations";
      break;
    }
    if (!std::isfinite(res)) {
      // Never hand back a poisoned state: fall back to the last checkpoint.
      xc = ck;
      E = eval(xc, false);
      rep.residual = residual(f.data());
      rep.message = "stopped: non-finite force at iteration " + std::to_string(it) + "; returned the last good state";
      break;
    }
    if (it >= st.max_iterations) {
      rep.message = "not converged: relative residual " + fmt(res) + " > " + fmt(st.tolerance) + " after " +
                    std::to_string(it) + " iterations (iteration budget)";
      break;
    }
    if (st.max_seconds > 0 && seconds_since(t0) > st.max_seconds) {
      rep.message = "not converged: relative residual " + fmt(res) + " > " + fmt(st.tolerance) + " after " +
                    fmt(seconds_since(t0)) + " s (time budget)";
      break;
    }
    if ((cancel && cancel->load()) ||
        (progress && st.progress_every > 0 && it % st.progress_every == 0 && !progress(it, res))) {
      rep.cancelled = true;
      rep.message = "cancelled at iteration " + std::to_string(it) + " (relative residual " + fmt(res) + ")";
      break;
    }

    // Block-Jacobi step.
    double dn2 = 0;
#pragma omp parallel for reduction(+ : dn2) schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const Vec3 fv = {f[3 * v], f[3 * v + 1], f[3 * v + 2]};
      Vec3 dv;
      Sym3 Dv = D[v];
      if (!sym3_solve_spd(Dv, fv, dv)) {
        const double tr = std::fabs(Dv.xx) + std::fabs(Dv.yy) + std::fabs(Dv.zz);
        Dv += sym3_identity(1e-6 * tr + 1e-12);
        if (!sym3_solve_spd(Dv, fv, dv)) dv = make_vec3(0, 0, 0);
      }
      dv = alpha * dv;
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
    // Chebyshev combination and the barrier-safe step: a vertex may close at
    // most half its gap along the SDF normal, and never moves further than
    // its gap or kFreeStep; a step that still lands too close (curved or
    // creased body) slides back out to half the old gap, or is dropped for
    // that vertex together with its momentum.
    int rejected = 0;
#pragma omp parallel for reduction(+ : rejected) schedule(static) num_threads(threads_)
    for (int v = 0; v < n_; ++v) {
      const Vec3 xo = {xc[3 * v], xc[3 * v + 1], xc[3 * v + 2]};
      Vec3 dv;
      dv.x = omega * d[3 * v] + (omega - 1.0) * (xc[3 * v] - xp[3 * v]);
      dv.y = omega * d[3 * v + 1] + (omega - 1.0) * (xc[3 * v + 1] - xp[3 * v + 1]);
      dv.z = omega * d[3 * v + 2] + (omega - 1.0) * (xc[3 * v + 2] - xp[3 * v + 2]);
      Vec3 xn = xo + dv;
      if (bar) {
        const SdfSample& s = S[v];
        const double gn = norm(s.grad);
        if (gn > 1e-12 && s.phi > 0) {
          const Vec3 nrm = (1.0 / gn) * s.grad;
          const double dn = dot(dv, nrm), lim = -beta * s.phi;
          if (dn < lim) dv -= (dn - lim) * nrm;
        }
        const double len = norm(dv), cap = std::max(0.9 * s.phi, kFreeStep);
        if (len > cap) dv = (cap / len) * dv;
        xn = xo + dv;
        SdfSample sn = sdf_at(xn);
        // Sliding along the body: where the body curves away from the tangent
        // plane (or creases), a step can close more than half the gap although
        // its normal part may not; such a step is pushed back out along the
        // field to its linear prediction phi + grad.dv (at least half the old
        // gap), a few Newton steps on phi. Failing that the vertex stays.
        // Steps that keep half the gap are left alone (pure descent).
        const double want = std::max(s.phi + dot(s.grad, dv), 0.5 * s.phi);
        for (int h = 0; h < 3 && sn.phi < 0.5 * s.phi && sn.phi < want; ++h) {
          const double g2 = norm2(sn.grad);
          if (!(g2 > 1e-12)) break;
          xn += ((want - sn.phi) / g2) * sn.grad;
          sn = sdf_at(xn);
        }
        if (sn.phi < 0.25 * s.phi || !(sn.phi > kProjectFloor) || norm(xn - xo) > 2.0 * std::max(len, 1e-300)) {
          xn = xo;
          sn = s;
          ++rejected;
        }
        S[v] = sn;
      }
      const bool stay = bar && xn.x == xo.x && xn.y == xo.y && xn.z == xo.z;
      // A dropped step also drops the vertex's momentum.
      xp[3 * v] = stay ? xn.x : xo.x;
      xp[3 * v + 1] = stay ? xn.y : xo.y;
      xp[3 * v + 2] = stay ? xn.z : xo.z;
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
      } else {
        ck = xc;
        Eck = E;
        rises = 0;
        // Still descending: widen the Chebyshev interval towards 1.
        if (auto_rho && k > warmup) rho = std::min(1.0 - 0.9 * (1.0 - rho), 0.99995);
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

SolveReport Simulator::solve_newton(double* x, const SolveSettings& st, const ProgressFn& progress,
                                    const std::atomic<bool>* cancel) {
  const auto t0 = Clock::now();
  SolveReport rep;
  const int n3 = 3 * n_;
  const bool bar = has_sdf_ && params_.mu > 0;
  const double gap = projection_gap();
  if (bar) rep.projections += project_outside(x, kProjectFloor, gap);

  Eigen::Map<Eigen::VectorXd> X(x, n3);
  Eigen::VectorXd f(n3), dx(n3), xt(n3);
  EnergyTerms et;
  double E = force(x, f.data(), &et);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool analysed = false;
  double shift = 0;  // Levenberg shift, relative to the mean diagonal
  int it = 0;
  for (;; ++it) {
    const double res = residual(f.data());
    rep.residual = res;
    if (st.history_every > 0) {
      rep.hist_iter.push_back(it);
      rep.hist_seconds.push_back(seconds_since(t0));
      rep.hist_residual.push_back(res);
    }
    if (res <= st.tolerance) {
      rep.converged = true;
      rep.message = "converged: relative residual " + fmt(res) + " <= " + fmt(st.tolerance) + " after " +
                    std::to_string(it) + " Newton iterations";
      break;
    }
    if (it >= st.max_iterations) {
      rep.message = "not converged: relative residual " + fmt(res) + " > " + fmt(st.tolerance) + " after " +
                    std::to_string(it) + " Newton iterations (iteration budget)";
      break;
    }
    if (st.max_seconds > 0 && seconds_since(t0) > st.max_seconds) {
      rep.message = "not converged: relative residual " + fmt(res) + " > " + fmt(st.tolerance) + " after " +
                    fmt(seconds_since(t0)) + " s (time budget)";
      break;
    }
    if ((cancel && cancel->load()) || (progress && !progress(it, res))) {
      rep.cancelled = true;
      rep.message = "cancelled at Newton iteration " + std::to_string(it) + " (relative residual " + fmt(res) + ")";
      break;
    }
    // Exact Hessian when it is positive definite (quadratic convergence near a
    // strict minimum); otherwise the PSD-projected one with a Levenberg shift.
    bool ok = false;
    if (st.newton_exact_first) {
      hessian(x, false);
      if (!analysed) {
        ldlt.analyzePattern(H_);
        analysed = true;
      }
      ldlt.factorize(H_);
      ok = ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0).all();
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
    if (!dx.allFinite()) {
      rep.message = "not converged: the Newton step is not finite (relative residual " + fmt(res) + ")";
      break;
    }
    // Backtracking; the energy is +inf for any state with a vertex inside the
    // body, so accepted steps end outside. Against tunnelling through a thin
    // part of the body, no vertex moves further than its distance to the body
    // (the SDF is 1-Lipschitz) or kFreeStep, whichever is larger.
    double tmax = 1.0;
    if (bar) {
      for (int v = 0; v < n_; ++v) {
        const double len = std::sqrt(dx[3 * v] * dx[3 * v] + dx[3 * v + 1] * dx[3 * v + 1] + dx[3 * v + 2] * dx[3 * v + 2]);
        if (len <= 0) continue;
        const double phi = sdf_at(make_vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2])).phi;
        tmax = std::min(tmax, std::max(0.9 * phi, kFreeStep) / len);
      }
    }
    const double slope = -f.dot(dx);  // dE/dt at t = 0 (negative)
    double t = tmax;
    bool accepted = false;
    EnergyTerms et_t;
    for (int ls = 0; ls < 60; ++ls) {
      xt = X + t * dx;
      const double Et = energy(xt.data(), &et_t);
      if (std::isfinite(Et) && Et <= E + 1e-4 * t * slope + energy_slack(et_t)) {
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (!accepted) {
      rep.message = "not converged: line search failed at relative residual " + fmt(res);
      break;
    }
    X = xt;
    E = force(x, f.data(), &et);
    shift = t >= 0.999 * tmax ? shift * 0.1 : shift;
    if (shift < 1e-12) shift = 0;
  }
  rep.iterations = it;
  rep.energy = E;
  rep.seconds = seconds_since(t0);
  return rep;
}

}  // namespace seamfit::sim
