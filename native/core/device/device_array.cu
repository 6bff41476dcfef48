#include "device/device_array.hpp"

#include <cmath>
#include <string>

#include "device/dev_buffer.cuh"

namespace seamfit::cuda {
namespace {

// Rounded twice, never fused: the host loop's NumPy y + a * x, bit for bit, so that the
// search on GPU state takes the host loop's path.
__global__ void k_axpy(double* y, const double* x, double a, size_t count) {
  for (size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < count; i += size_t(gridDim.x) * blockDim.x)
    y[i] = __dadd_rn(y[i], __dmul_rn(a, x[i]));
}

// One block: a grid-stride max, then a block max. NaN wins (fmax would drop it).
__global__ void k_max_abs(const double* x, size_t count, double* out) {
  __shared__ double sh[1024];
  double m = 0.0;
  for (size_t i = threadIdx.x; i < count; i += blockDim.x) {
    const double a = fabs(x[i]);
    m = (a > m || a != a) ? a : m;
  }
  sh[threadIdx.x] = m;
  __syncthreads();
  for (int s = blockDim.x / 2; s > 0; s >>= 1) {
    if (threadIdx.x < s) {
      const double o = sh[threadIdx.x + s];
      if (o > sh[threadIdx.x] || o != o) sh[threadIdx.x] = o;
    }
    __syncthreads();
  }
  if (threadIdx.x == 0) out[0] = sh[0];
}

// DeviceArray's work runs on the legacy default stream, but its arrays are read and
// written by the CUDA classes' own streams, made with cudaStreamNonBlocking: those do
// not wait for the legacy stream. cudaMemset and a device-to-device cudaMemcpy return
// before the device has done them, and a cudaMemcpy from pageable host memory may
// return before its DMA has landed; so each operation here waits for the legacy
// stream before it returns (the "returns once complete" of device_array.hpp), and a
// kernel on another stream that reads or writes the array next sees it settled. A
// stream sync, not a device sync: other streams' work (all synchronized by their own
// entry points before they return) is not waited for.
void settle() { SF_CUDA(cudaStreamSynchronize(0)); }

}  // namespace

DeviceArray::DeviceArray(int rows, int cols) : rows_(rows), cols_(cols) {
  if (rows < 0 || cols < 0) throw CudaError("DeviceArray: negative shape");
  SF_CUDA(cudaMalloc(&p_, std::max<size_t>(size(), 1) * sizeof(double)));
  SF_CUDA(cudaMalloc(&scratch_, sizeof(double)));
  SF_CUDA(cudaMemset(p_, 0, std::max<size_t>(size(), 1) * sizeof(double)));
  settle();  // zeroed before another stream writes a result into it (else the memset may land after)
}

DeviceArray::~DeviceArray() {
  cudaFree(p_);
  cudaFree(scratch_);
}

void DeviceArray::upload(const double* host) {
  if (!size()) return;
  SF_CUDA(cudaMemcpy(p_, host, size() * sizeof(double), cudaMemcpyHostToDevice));
  settle();  // from pageable memory cudaMemcpy may return before the DMA has landed
}

void DeviceArray::download(double* host) const {
  if (size()) SF_CUDA(cudaMemcpy(host, p_, size() * sizeof(double), cudaMemcpyDeviceToHost));
}

void DeviceArray::copy_from(const DeviceArray& other) {
  if (other.size() != size())
    throw CudaError("DeviceArray: copy of " + std::to_string(other.size()) + " entries into " + std::to_string(size()));
  if (size() && other.p_ != p_) {
    SF_CUDA(cudaMemcpy(p_, other.p_, size() * sizeof(double), cudaMemcpyDeviceToDevice));
    settle();  // a device-to-device cudaMemcpy does not wait for the copy
  }
}

void DeviceArray::axpy(double a, const DeviceArray& x) {
  if (x.size() != size())
    throw CudaError("DeviceArray: axpy of " + std::to_string(x.size()) + " entries into " + std::to_string(size()));
  if (!size()) return;
  const int blocks = int(std::min<size_t>((size() + 255) / 256, 1024));
  k_axpy<<<blocks, 256>>>(p_, x.p_, a, size());
  SF_CUDA(cudaGetLastError());
  settle();
}

double DeviceArray::max_abs() const {
  if (!size()) return 0.0;
  k_max_abs<<<1, 1024>>>(p_, size(), scratch_);
  SF_CUDA(cudaGetLastError());
  double m = 0;
  SF_CUDA(cudaMemcpy(&m, scratch_, sizeof(double), cudaMemcpyDeviceToHost));
  return m;
}

}  // namespace seamfit::cuda
