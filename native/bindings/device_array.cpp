// seamfit._core.DeviceArray: a float64 array in GPU memory that the CUDA classes take
// in place of NumPy arrays (their *_device methods), so the grading loop's state stays
// on the GPU between exact checkpoints.
#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "py_device_array.hpp"

namespace py = pybind11;

namespace seamfit::bindings {

// Binds DeviceArray (CUDA builds only).
void bind_device_array(py::module_& m) {
#ifdef SEAMFIT_WITH_CUDA
  using seamfit::cuda::DeviceArray;
  using DArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
  auto shape_of = [](const DArr& a) {
    if (a.ndim() != 2) throw py::value_error("a DeviceArray holds a 2-D array, got " + std::to_string(a.ndim()) + "-D");
    return std::make_pair(int(a.shape(0)), int(a.shape(1)));
  };
  py::class_<DeviceArray>(m, "DeviceArray", "A 2-D float64 array in GPU memory.")
      .def(py::init([shape_of](const DArr& a) {
             const auto [r, c] = shape_of(a);
             auto* d = new DeviceArray(r, c);
             d->upload(a.data());
             return d;
           }),
           py::arg("array"), "A copy of a 2-D array on the GPU.")
      .def_static("zeros", [](int rows, int cols) { return new DeviceArray(rows, cols); }, py::arg("rows"),
                  py::arg("cols"), "A (rows, cols) array of zeros on the GPU.")
      .def_property_readonly(
          "shape", [](const DeviceArray& d) { return py::make_tuple(d.rows(), d.cols()); }, "(rows, cols)")
      .def("numpy",
           [](const DeviceArray& d) {
             py::array_t<double> out({py::ssize_t(d.rows()), py::ssize_t(d.cols())});
             d.download(out.mutable_data());
             return out;
           },
           "A host copy.")
      .def("upload",
           [shape_of](DeviceArray& d, const DArr& a) {
             const auto [r, c] = shape_of(a);
             if (r != d.rows() || c != d.cols())
               throw py::value_error("upload: an array of shape (" + std::to_string(r) + ", " + std::to_string(c) +
                                     ") into a DeviceArray of shape (" + std::to_string(d.rows()) + ", " +
                                     std::to_string(d.cols()) + ")");
             d.upload(a.data());
           },
           py::arg("array"), "Overwrite with a host array of the same shape.")
      .def("copy_from", &DeviceArray::copy_from, py::arg("other"), "Overwrite with a DeviceArray of the same shape.")
      .def("axpy", &DeviceArray::axpy, py::arg("a"), py::arg("x"), "self += a * x")
      .def("max_abs", &DeviceArray::max_abs, "max |entry| (NaN if any entry is).");
#else
  (void)m;
#endif
}

}  // namespace seamfit::bindings
