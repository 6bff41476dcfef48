// The one exception of the CUDA code: a CUDA runtime failure or a missing device.
// The bindings turn it into seamfit.errors.DeviceError. Host-only, no CUDA types,
// so any domain's GPU half can throw it without including another domain.
#pragma once
#include <stdexcept>

namespace seamfit::cuda {

struct CudaError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace seamfit::cuda
