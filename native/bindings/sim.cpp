#include "bindings.hpp"

namespace py = pybind11;

namespace seamfit::bindings {

void bind_sim(py::module_& m) { (void)m; }

}  // namespace seamfit::bindings
