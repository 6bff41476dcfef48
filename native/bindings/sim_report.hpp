// Python faces of the simulator's energy terms and solve report, shared by the
// CPU (sim.cpp) and CUDA (cuda_sim.cpp) bindings so both report the same keys.
#pragma once
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <utility>

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
  d["final_rho"] = r.final_rho;
  d["final_alpha"] = r.final_alpha;
  d["linear_iterations"] = r.linear_iterations;
  d["message"] = r.message;
  d["history_iteration"] = r.hist_iter;
  d["history_seconds"] = r.hist_seconds;
  d["history_residual"] = r.hist_residual;
  return d;
}

// (energy, terms) at x (n, 3) of a CPU or GPU simulator, computed with the GIL released.
template <class Sim>
pybind11::tuple energy_and_terms(Sim& s, const double* x) {
  sim::EnergyTerms t;
  double e;
  {
    pybind11::gil_scoped_release nogil;
    e = s.energy(x, &t);
  }
  return pybind11::make_tuple(e, terms_dict(t));
}

// Runs solve(fn, cancel) with the GIL released, fn relaying progress(it, res)
// to Python (None: no callback). The callback runs with the GIL retaken; one
// that raises cancels the solve, and its exception is re-raised afterwards.
template <class Solve>
auto with_progress(const pybind11::object& progress, Solve&& solve) {
  namespace py = pybind11;
  sim::ProgressFn fn;
  std::atomic<bool> cancel{false};
  bool py_error = false;
  py::object err_type, err_value, err_tb;
  if (!progress.is_none()) {
    fn = [&](int it, double res) -> bool {
      py::gil_scoped_acquire gil;
      try {
        py::object r = progress(it, res);
        return r.is_none() || r.cast<bool>();
      } catch (py::error_already_set& e) {
        py_error = true;
        e.restore();
        PyObject *t, *v, *tb;
        PyErr_Fetch(&t, &v, &tb);
        err_type = py::reinterpret_steal<py::object>(t);
        err_value = py::reinterpret_steal<py::object>(v);
        err_tb = py::reinterpret_steal<py::object>(tb);
        return false;
      }
    };
  }
  decltype(solve(fn, &cancel)) out;
  {
    py::gil_scoped_release nogil;
    out = solve(fn, &cancel);
  }
  if (py_error) {
    PyErr_Restore(err_type.release().ptr(), err_value.release().ptr(), err_tb.release().ptr());
    throw py::error_already_set();
  }
  return out;
}

}  // namespace seamfit::bindings
