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
  using namespace pybind11::literals;
  return pybind11::dict("stretch"_a = t.stretch, "sewing"_a = t.sewing, "bending"_a = t.bending,
                        "gravity"_a = t.gravity, "sticking"_a = t.sticking, "barrier"_a = t.barrier);
}

inline pybind11::dict report_dict(const sim::SolveReport& r) {
  using namespace pybind11::literals;
  return pybind11::dict("iterations"_a = r.iterations, "seconds"_a = r.seconds, "residual"_a = r.residual,
                        "energy"_a = r.energy, "converged"_a = r.converged, "cancelled"_a = r.cancelled,
                        "restarts"_a = r.restarts, "projections"_a = r.projections,
                        "rejected_steps"_a = r.rejected_steps, "final_rho"_a = r.final_rho,
                        "final_alpha"_a = r.final_alpha, "linear_iterations"_a = r.linear_iterations,
                        "message"_a = r.message, "history_iteration"_a = r.hist_iter,
                        "history_seconds"_a = r.hist_seconds, "history_residual"_a = r.hist_residual);
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
