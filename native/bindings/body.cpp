#include "bindings.hpp"

namespace py = pybind11;

namespace seamfit::bindings {

void bind_body(py::module_& m) { (void)m; }

}  // namespace seamfit::bindings
