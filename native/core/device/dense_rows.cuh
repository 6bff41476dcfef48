// Dense matrix-vector products over row-major blocks, one warp per row: p(theta) and its
// adjoint (pattern_gpu.cu, K = 2: one coefficient for the x and y of a pattern vector) and
// the preconditioner P^-1 g (regularizers_gpu.cu, K = 1: one (2 n_theta)^2 block).
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

namespace seamfit::cuda {

constexpr int kDenseRowsThreads = 256;  // 8 warps, one row each

// out[r] = A_b(r) in_b(r) for dense row-major blocks laid end to end: row r of
// the stacked rows belongs to block b, whose rows start at row0[b], whose
// matrix starts at A + offset[b] with ncols[b] columns, and whose input is
// in[K col0[b] ...] (K interleaved components per entry, each multiplied by the
// same coefficient).
struct DenseRows {
  int rows = 0;
  const int32_t *row_block = nullptr, *row0 = nullptr, *col0 = nullptr, *ncols = nullptr;
  const int64_t* offset = nullptr;
  const double* A = nullptr;
  const double* in = nullptr;
  double* out = nullptr;
};

// One warp per row, its lanes striding the row (coalesced), summed in a fixed order:
// the same result on every call.
template <int K>
__global__ void __launch_bounds__(kDenseRowsThreads) k_dense_rows(DenseRows d) {
  const int r = int((int64_t(blockIdx.x) * blockDim.x + threadIdx.x) >> 5), lane = threadIdx.x & 31;
  if (r >= d.rows) return;  // whole warps leave together
  const int b = d.row_block[r], nc = d.ncols[b];
  const double* a = d.A + d.offset[b] + int64_t(r - d.row0[b]) * nc;
  const double* x = d.in + K * int64_t(d.col0[b]);
  double s[K];
#pragma unroll
  for (int k = 0; k < K; ++k) s[k] = 0;
  for (int c = lane; c < nc; c += 32) {
    const double m = a[c];
#pragma unroll
    for (int k = 0; k < K; ++k) s[k] += m * x[K * c + k];
  }
#pragma unroll
  for (int k = 0; k < K; ++k)
    for (int o = 16; o > 0; o >>= 1) s[k] += __shfl_down_sync(0xffffffffu, s[k], o);
  if (lane == 0)
#pragma unroll
    for (int k = 0; k < K; ++k) d.out[K * int64_t(r) + k] = s[k];
}

template <int K>
inline void launch_dense_rows(const DenseRows& d, cudaStream_t s) {
  if (d.rows)
    k_dense_rows<K><<<unsigned((int64_t(d.rows) * 32 + kDenseRowsThreads - 1) / kDenseRowsThreads),
                      kDenseRowsThreads, 0, s>>>(d);
}

}  // namespace seamfit::cuda
