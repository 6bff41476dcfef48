// The body's distance field on a GPU: the exact distance from every grid node to
// the nearest triangle (one BVH query per node), the part of sdf_build that
// params.gpu hands over; the sign stays on the CPU. Host-only interface.
#pragma once
#include "body/sdf_build.hpp"

namespace seamfit::cuda {

// body::SdfGpuDistancesFn: out[i + nx*(j + ny*k)] = float(sqrt(d2)) to the nearest
// triangle, on the current CUDA device. Throws CudaError (no GPU, not enough memory,
// a failed kernel), naming what failed.
void sdf_gpu_distances(const body::SdfGpuInput& in, float* out);

}  // namespace seamfit::cuda
