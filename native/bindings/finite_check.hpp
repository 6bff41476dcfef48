// Refuse non-finite inputs at the binding boundary: NaN coordinates make the native
// searches (BVH descents, closest-point queries) misbehave inside OpenMP regions,
// where a crash takes the interpreter with it. A ValueError names the first bad row.
#pragma once
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <string>

namespace seamfit::bindings {

// data: rows x cols doubles (row-major).
inline void require_finite_rows(const double* data, int64_t rows, int64_t cols, const char* what) {
  for (int64_t r = 0; r < rows; ++r)
    for (int64_t c = 0; c < cols; ++c)
      if (!std::isfinite(data[r * cols + c]))
        throw pybind11::value_error(std::string(what) + ": row " + std::to_string(r) +
                                    " has a non-finite value (NaN or infinity)");
}

// After sampling an SDF: a non-finite result means non-finite grid values near that point.
inline void require_finite_samples(const double* phi, const double* grad, int64_t n) {
  for (int64_t q = 0; q < n; ++q)
    if (!std::isfinite(phi[q]) || !std::isfinite(grad[3 * q]) || !std::isfinite(grad[3 * q + 1]) ||
        !std::isfinite(grad[3 * q + 2]))
      throw pybind11::value_error("SDF sample at point " + std::to_string(q) +
                                  " is not finite: the field has NaN or infinite values there");
}

}  // namespace seamfit::bindings
