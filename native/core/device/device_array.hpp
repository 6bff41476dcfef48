// A float64 array in device memory that the outer loop's GPU pieces hand to one
// another (the garment state x, theta, the pattern p, gradients), so that nothing
// garment-sized crosses to the host between two exact checkpoints: the host reads
// scalars only. Host-only interface: no CUDA types.
#pragma once
#include <cstddef>

namespace seamfit::cuda {

class DeviceArray {
 public:
  // rows x cols doubles, zeroed.
  DeviceArray(int rows, int cols);
  ~DeviceArray();
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  size_t size() const { return size_t(rows_) * size_t(cols_); }
  double* data() { return p_; }
  const double* data() const { return p_; }

  // Whole-array copies; each returns once the copy is complete.
  void upload(const double* host);
  void download(double* host) const;
  void copy_from(const DeviceArray& other);  // same size
  // this += a * x (same size; rounded as NumPy rounds it), and max |entry| (0 when
  // empty; NaN when any entry is).
  void axpy(double a, const DeviceArray& x);
  double max_abs() const;

 private:
  int rows_ = 0, cols_ = 0;
  double* p_ = nullptr;
  double* scratch_ = nullptr;  // one double: max_abs's result
};

}  // namespace seamfit::cuda
