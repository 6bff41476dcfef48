// The translation of the core's exception types to seamfit.errors, shared by the
// simulator's (sim.cpp) and the CUDA backend's (cuda_sim.cpp) bindings.
#pragma once
#include <pybind11/pybind11.h>

#include <exception>

namespace seamfit::bindings {

// Registers the translation of E (and only it) to seamfit.errors.<Name>, message kept.
// Name: a char array of static storage (a template argument, since pybind11 takes
// the translator as a plain function).
template <class E, const char* Name>
void bind_error() {
  pybind11::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const E& e) {
      pybind11::object cls = pybind11::module_::import("seamfit.errors").attr(Name);
      PyErr_SetString(cls.ptr(), e.what());
    }
  });
}

}  // namespace seamfit::bindings
