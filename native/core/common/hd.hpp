// Host-device qualifiers: every energy and cost is written once and compiled for
// both the CPU path (g++) and the CUDA path (nvcc).
#pragma once

#if defined(__CUDACC__)
#define SF_HD __host__ __device__ __forceinline__
#define SF_HOST_DEVICE __host__ __device__
#else
#define SF_HD inline
#define SF_HOST_DEVICE
#endif
