// The solve reports' messages, one wording for the CPU solvers (sim/solvers.cpp)
// and the GPU's (sim/sim_gpu.cu): callers and tests read their verdicts from
// these words ("converged", "iteration budget", "time budget", "cancelled").
#pragma once
#include <cstdio>
#include <string>

namespace seamfit::sim {

inline std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// `what` names the iterations ("iterations", "Newton iterations").
inline std::string msg_converged(double res, double tol, int it, const char* what) {
  return "converged: relative residual " + fmt(res) + " <= " + fmt(tol) + " after " + std::to_string(it) + " " + what;
}

inline std::string msg_iteration_budget(double res, double tol, int it, const char* what) {
  return "not converged: relative residual " + fmt(res) + " > " + fmt(tol) + " after " + std::to_string(it) + " " +
         what + " (iteration budget)";
}

inline std::string msg_time_budget(double res, double tol, double seconds) {
  return "not converged: relative residual " + fmt(res) + " > " + fmt(tol) + " after " + fmt(seconds) +
         " s (time budget)";
}

inline std::string msg_non_finite(int it) {
  return "stopped: non-finite force at iteration " + std::to_string(it) + "; returned the last good state";
}

// `what` names one iteration ("iteration", "Newton iteration").
inline std::string msg_cancelled(double res, int it, const char* what) {
  return std::string("cancelled at ") + what + " " + std::to_string(it) + " (relative residual " + fmt(res) + ")";
}

}  // namespace seamfit::sim
