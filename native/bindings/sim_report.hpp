// Python faces of the simulator's energy terms and solve report, shared by the
// CPU (sim.cpp) and CUDA (cuda_sim.cpp) bindings so both report the same keys.
#pragma once
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "sim/simulator.hpp"

namespace seamfit::bindings {

inline pybind11::dict terms_dict(const sim::EnergyTerms& t) {
  pybind11::dict d;
  d["stretch"] = t.stretch;
  d["sewing"] = t.sewing;
  d["bending"] = t.bending;
  d["gravity"] = t.gravity;
  d["sticking"] = t.sticking;
  d["barrier"] = t.barrier;
  return d;
}

inline pybind11::dict report_dict(const sim::SolveReport& r) {
  pybind11::dict d;
  d["iterations"] = r.iterations;
  d["seconds"] = r.seconds;
  d["residual"] = r.residual;
  d["energy"] = r.energy;
  d["converged"] = r.converged;
  d["cancelled"] = r.cancelled;
  d["restarts"] = r.restarts;
  d["projections"] = r.projections;
  d["rejected_steps"] = r.rejected_steps;
  d["momentum_restarts"] = r.momentum_restarts;
  d["final_rho"] = r.final_rho;
  d["final_alpha"] = r.final_alpha;
  d["message"] = r.message;
  d["history_iteration"] = r.hist_iter;
  d["history_seconds"] = r.hist_seconds;
  d["history_residual"] = r.hist_residual;
  return d;
}

}  // namespace seamfit::bindings
