#include "body/sdf_gpu.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <string>
#include <vector>

#include "body/tri_bvh.hpp"
#include "body/tri_distance.hpp"
#include "device/dev_buffer.cuh"
#include "device/cuda_error.hpp"

namespace seamfit::cuda {

namespace {

using body::BvhNode;
using body::TriPre;

// x nodes per thread: each query after the first starts from the triangle nearest
// to the node before. Threads of a warp take neighbouring runs of one x row, so
// their traversals visit nearly the same BVH nodes.
constexpr int kRun = 4;
constexpr int kBlock = 128;

struct GridArgs {
  double o[3];
  double h;
  int64_t nx, ny, nz, runs_x;
};

__global__ void __launch_bounds__(kBlock) k_sdf_distances(const BvhNode* __restrict__ nodes,
                                                          const TriPre* __restrict__ tris, GridArgs g,
                                                          int64_t total, float* __restrict__ out) {
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  for (int64_t t = int64_t(blockIdx.x) * blockDim.x + threadIdx.x; t < total; t += stride) {
    const int64_t r = t % g.runs_x, row = t / g.runs_x;  // row = j + ny * k
    const int64_t j = row % g.ny, k = row / g.ny;
    const int64_t i0 = r * kRun, i1 = min(g.nx, i0 + kRun);
    body::bvh_distance_run(nodes, tris, g.o, g.h, i0, i1, j, k, out + row * g.nx + i0);
  }
}

struct Stream {
  cudaStream_t s = nullptr;
  Stream() { SF_CUDA(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking)); }
  ~Stream() {
    if (s) cudaStreamDestroy(s);
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
};

}  // namespace

void sdf_gpu_distances(const body::SdfGpuInput& in, float* out) {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess || count == 0) {
    cudaGetLastError();
    throw CudaError("device cuda: no CUDA GPU or driver is present to build the SDF on");
  }
  const int64_t nx = in.dims[0], ny = in.dims[1], nz = in.dims[2];
  const int64_t n = nx * ny * nz;
  if (n <= 0 || in.n_tris <= 0 || in.n_nodes <= 0) throw CudaError("SDF on the GPU: empty grid or mesh");
  const size_t out_bytes = size_t(n) * sizeof(float);
  const size_t need = out_bytes + size_t(in.n_tris) * sizeof(TriPre) + size_t(in.n_nodes) * sizeof(BvhNode);
  size_t free_b = 0, total_b = 0;
  SF_CUDA(cudaMemGetInfo(&free_b, &total_b));
  if (need > free_b)
    throw CudaError("the SDF of " + std::to_string(n) + " nodes needs " + std::to_string(need >> 20) +
                    " MiB of GPU memory, " + std::to_string(free_b >> 20) +
                    " MiB are free; use a larger spacing or smaller bounds, or device cpu");

  // Triangles in BVH leaf order: a leaf's triangles are contiguous, and the kernel
  // needs no index array.
  std::vector<TriPre> leaf(static_cast<size_t>(in.n_tris));
  for (int64_t q = 0; q < in.n_tris; ++q) leaf[q] = in.tris[in.order[q]];

  Stream st;
  DevBuf d_nodes, d_tris, d_out;
  upload(d_nodes, in.nodes, size_t(in.n_nodes), st.s);
  upload(d_tris, leaf.data(), leaf.size(), st.s);
  d_out.reserve(out_bytes);

  GridArgs g;
  for (int a = 0; a < 3; ++a) g.o[a] = in.origin[a];
  g.h = in.spacing;
  g.nx = nx;
  g.ny = ny;
  g.nz = nz;
  g.runs_x = (nx + kRun - 1) / kRun;
  const int64_t total = g.runs_x * ny * nz;
  const int64_t blocks = std::min<int64_t>((total + kBlock - 1) / kBlock, int64_t(1) << 30);
  k_sdf_distances<<<unsigned(blocks), kBlock, 0, st.s>>>(d_nodes.as<BvhNode>(), d_tris.as<TriPre>(), g, total,
                                                          d_out.as<float>());
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaMemcpyAsync(out, d_out.p, out_bytes, cudaMemcpyDeviceToHost, st.s));
  SF_CUDA(cudaStreamSynchronize(st.s));
}

}  // namespace seamfit::cuda
