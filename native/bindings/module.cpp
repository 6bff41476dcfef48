#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "seamfit compiled core: signed distance fields, quasistatic simulation, optimization";
  seamfit::bindings::bind_device(m);
  seamfit::bindings::bind_device_array(m);
  seamfit::bindings::bind_body(m);
  seamfit::bindings::bind_sim(m);
  seamfit::bindings::bind_opt(m);
  seamfit::bindings::bind_cuda_sim(m);
}
