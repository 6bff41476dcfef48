// Device allocations and error checks shared by the CUDA translation units.
#pragma once
#include <cuda_runtime.h>

#include <algorithm>
#include <cstddef>
#include <string>

#include "device/cuda_error.hpp"

namespace seamfit::cuda {

inline void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw CudaError(std::string("CUDA error in ") + what + ": " + cudaGetErrorString(e));
}
#define SF_CUDA(call) ::seamfit::cuda::check((call), #call)

// Owning device allocation.
struct DevBuf {
  void* p = nullptr;
  size_t bytes = 0;
  DevBuf() = default;
  DevBuf(const DevBuf&) = delete;
  DevBuf& operator=(const DevBuf&) = delete;
  ~DevBuf() { release(); }
  void release() {
    if (p) cudaFree(p);
    p = nullptr;
    bytes = 0;
  }
  // Keeps the allocation when it is large enough; returns true if it moved.
  bool reserve(size_t b) {
    if (b <= bytes && p) return false;
    release();
    SF_CUDA(cudaMalloc(&p, std::max<size_t>(b, 16)));
    bytes = std::max<size_t>(b, 16);
    return true;
  }
  template <class T>
  T* as() const { return static_cast<T*>(p); }
};

template <class T>
void upload(DevBuf& b, const T* h, size_t count, cudaStream_t s) {
  b.reserve(count * sizeof(T));
  if (count) SF_CUDA(cudaMemcpyAsync(b.p, h, count * sizeof(T), cudaMemcpyHostToDevice, s));
}

// sh[q][0] = the sum of sh[q][0..blockDim.x) for each q, by halving (blockDim.x a
// power of two, at most N) in a fixed order, so that the sum does not depend on
// which block computes it. Every thread of the block calls it once its own
// sh[q][threadIdx.x] are written.
template <int Q, int N>
__device__ void tree_sum(double (&sh)[Q][N]) {
  const int t = threadIdx.x;
  __syncthreads();
  for (int w = blockDim.x / 2; w > 0; w >>= 1) {
    if (t < w)
      for (int q = 0; q < Q; ++q) sh[q][t] += sh[q][t + w];
    __syncthreads();
  }
}

// Sum of Q values over the block, written to out[0..Q-1] by thread 0.
template <int Q>
__device__ void block_sum(double (&v)[Q], double* out) {
  __shared__ double sh[Q][32];
  const int lane = threadIdx.x & 31, w = threadIdx.x >> 5, nw = (blockDim.x + 31) >> 5;
#pragma unroll
  for (int q = 0; q < Q; ++q)
    for (int o = 16; o > 0; o >>= 1) v[q] += __shfl_down_sync(0xffffffffu, v[q], o);
  if (lane == 0)
#pragma unroll
    for (int q = 0; q < Q; ++q) sh[q][w] = v[q];
  __syncthreads();
  if (w == 0) {
#pragma unroll
    for (int q = 0; q < Q; ++q) {
      double a = lane < nw ? sh[q][lane] : 0.0;
      for (int o = 16; o > 0; o >>= 1) a += __shfl_down_sync(0xffffffffu, a, o);
      if (lane == 0) out[q] = a;
    }
  }
}

}  // namespace seamfit::cuda
