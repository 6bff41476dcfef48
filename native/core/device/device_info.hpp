// Host-side queries of the CUDA runtime; safe on machines with no GPU or driver.
#pragma once
#include <string>

namespace seamfit::cuda {
int device_count();
std::string device_name(int index);
}  // namespace seamfit::cuda
