#include <cuda_runtime.h>

#include "device/device_info.hpp"

namespace seamfit::cuda {

int device_count() {
  int n = 0;
  // No driver or no GPU is a normal situation for the CPU path: report 0 quietly.
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return n;
}

std::string device_name(int index) {
  if (index < 0 || index >= device_count()) return std::string();
  cudaDeviceProp prop;
  if (cudaGetDeviceProperties(&prop, index) != cudaSuccess) return std::string();
  return std::string(prop.name);
}

}  // namespace seamfit::cuda
