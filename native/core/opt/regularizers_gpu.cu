#include "opt/regularizers_gpu.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "device/dense_rows.cuh"
#include "device/dev_buffer.cuh"
#include "opt/costs/gather.hpp"
#include "opt/costs/regularizers.hpp"
#include "opt/costs/seam_length.hpp"
#include "sim/sim_gpu.hpp"

namespace seamfit::cuda {

namespace {

constexpr int kBlock = 256;
int blocks(int n) { return (n + kBlock - 1) / kBlock; }

// R^fix + R^cur: the CPU's steps (opt::Regularizers::evaluate) as kernels.
struct RegArgs {
  int nt = 0, ne = 0;
  double fix = 0, cur = 0;
  const Vec2 *theta = nullptr, *theta_bar = nullptr, *z = nullptr;
  const int *elem = nullptr, *off = nullptr, *slots = nullptr;
  const double* w = nullptr;
  double* val_cur = nullptr;
  Vec2* slot = nullptr;
  Vec2* grad = nullptr;
  double* part = nullptr;  // per block: (R^fix, R^cur)
};

__global__ void k_curve(RegArgs a) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= a.ne) return;
  a.val_cur[e] = curve_element(a.theta, a.elem + 3 * e, a.z[e], a.cur * a.w[e], a.slot + 3 * e);
}

// Thread t: the gradient of theta entry t, R^fix at t and curve element t's value, the
// two values summed per block (no early return: block_sum synchronizes the block).
__global__ void k_reg_gather(RegArgs a) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  double v[2] = {0.0, 0.0};
  if (t < a.nt)
    a.grad[t] = regularizer_gradient_at(t, a.theta, a.theta_bar, a.fix, a.cur != 0, a.off, a.slots, a.slot, &v[0]);
  if (a.cur != 0 && t < a.ne) v[1] = a.val_cur[t];
  block_sum<2>(v, a.part + 2 * blockIdx.x);
}

// R^seam: the CPU's steps (opt::SeamLength::evaluate) as kernels.
struct SeamArgs {
  int nt = 0, ns = 0;
  double k = 0;
  const Vec2* theta = nullptr;
  const int *seg = nullptr, *off = nullptr, *slots = nullptr;
  const double* rho = nullptr;
  double* val = nullptr;
  Vec2* slot = nullptr;
  Vec2* grad = nullptr;
  double* part = nullptr;
};

__global__ void k_seam(SeamArgs a) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= a.ns) return;
  a.val[s] = seam_element(a.theta, a.seg + 4 * s, a.rho[s], a.k, a.slot + 4 * s);
}

__global__ void k_seam_gather(SeamArgs a) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  double v[1] = {0.0};
  if (t < a.nt) {
    Vec2 g = make_vec2(0, 0);
    gather_add(t, a.off, a.slots, a.slot, g);
    a.grad[t] = g;
  }
  if (t < a.ns) v[0] = a.val[t];
  block_sum<1>(v, a.part + blockIdx.x);
}

// The host's fixed-order sum of Q-valued block partials, copied back from the device.
template <int Q>
std::array<double, Q> sum_partials(const double* part, int nblocks, std::vector<double>& host, cudaStream_t s) {
  host.resize(size_t(Q) * nblocks);
  SF_CUDA(cudaMemcpyAsync(host.data(), part, host.size() * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  std::array<double, Q> t{};
  for (int b = 0; b < nblocks; ++b)
    for (int q = 0; q < Q; ++q) t[q] += host[size_t(Q) * b + q];
  return t;
}

std::string mib(size_t b) { return std::to_string(b >> 20); }

}  // namespace

struct RegularizersGpu::Impl {
  const opt::Regularizers* obj = nullptr;
  opt::Regularizers* pre = nullptr;
  cudaStream_t stream = nullptr;
  int nt = 0, ne = 0;
  // out: the host path's gradient, then the block partials.
  DevBuf theta, theta_bar, z, w, elem, off, slots, val_cur, slot, out;
  // P^-1 as one dense block of 2 n_theta rows; its row tables and the host path's vectors in and out.
  DevBuf inv, row_block, row0, col0, ncols, offset, gin, gout;
  DenseRows rows;  // in and out set per call
  long built = -1;  // precond's preconditioner_version when P^-1 was built
  long builds = 0;
  std::vector<double> host;  // block partials
  ~Impl() {
    if (stream) cudaStreamDestroy(stream);
  }
};

RegularizersGpu::RegularizersGpu(const opt::Regularizers& objective, opt::Regularizers& precond, size_t max_bytes)
    : impl_(new Impl) {
  Impl& I = *impl_;
  if (objective.n_theta() != precond.n_theta())
    throw std::invalid_argument("the objective's and the preconditioner's regularizers differ in n_theta");
  I.obj = &objective;
  I.pre = &precond;
  I.nt = objective.n_theta();
  I.ne = int(objective.curve_elements().size());
  const size_t bytes = inverse_bytes(I.nt);
  size_t free_b = 0, total_b = 0;
  SF_CUDA(cudaMemGetInfo(&free_b, &total_b));
  if (bytes > max_bytes || bytes > free_b / 2)
    throw CudaError("the preconditioner P^-1 needs " + mib(bytes) + " MiB of GPU memory (limit " +
                    mib(std::min(max_bytes, free_b / 2)) + " MiB)");
  SF_CUDA(cudaStreamCreateWithFlags(&I.stream, cudaStreamNonBlocking));
  cudaStream_t s = I.stream;
  const int nt = I.nt, ne = I.ne, n = 2 * nt;
  const opt::Gather& G = objective.curve_gather();
  upload(I.theta_bar, reinterpret_cast<const double*>(objective.theta_bar().data()), 2 * size_t(nt), s);
  upload(I.z, reinterpret_cast<const double*>(objective.curve_frames().data()), 2 * size_t(ne), s);
  upload(I.w, objective.curve_weights().data(), size_t(ne), s);
  upload(I.elem, ne ? objective.curve_elements()[0].data() : nullptr, 3 * size_t(ne), s);
  upload(I.off, G.offsets.data(), G.offsets.size(), s);
  upload(I.slots, G.slots.data(), G.slots.size(), s);
  I.theta.reserve(2 * size_t(std::max(nt, 1)) * sizeof(double));
  I.val_cur.reserve(size_t(std::max(ne, 1)) * sizeof(double));
  I.slot.reserve(6 * size_t(std::max(ne, 1)) * sizeof(double));
  const int nb = blocks(std::max(std::max(nt, ne), 1));
  I.out.reserve((2 * size_t(nt) + 2 * size_t(nb)) * sizeof(double));
  // P^-1: claimed now, filled on the first apply_preconditioner.
  I.inv.reserve(std::max<size_t>(bytes, 16));
  const std::vector<int32_t> row_block(size_t(std::max(n, 1)), 0), zero{0}, nc{n};
  const std::vector<int64_t> off0{0};
  upload(I.row_block, row_block.data(), row_block.size(), s);
  upload(I.row0, zero.data(), 1, s);
  upload(I.col0, zero.data(), 1, s);
  upload(I.ncols, nc.data(), 1, s);
  upload(I.offset, off0.data(), 1, s);
  I.gin.reserve(size_t(std::max(n, 1)) * sizeof(double));
  I.gout.reserve(size_t(std::max(n, 1)) * sizeof(double));
  I.rows.rows = n;
  I.rows.row_block = I.row_block.as<int32_t>();
  I.rows.row0 = I.row0.as<int32_t>();
  I.rows.col0 = I.col0.as<int32_t>();
  I.rows.ncols = I.ncols.as<int32_t>();
  I.rows.offset = I.offset.as<int64_t>();
  I.rows.A = I.inv.as<double>();
  SF_CUDA(cudaStreamSynchronize(s));  // the host vectors go out of scope
}

RegularizersGpu::~RegularizersGpu() = default;

double RegularizersGpu::evaluate(const Vec2* theta, Vec2* grad, std::array<double, 2>* terms) {
  Impl& I = *impl_;
  cudaStream_t s = I.stream;
  const size_t n = 2 * size_t(I.nt);
  upload(I.theta, reinterpret_cast<const double*>(theta), n, s);
  const double value = evaluate_device(I.theta.as<double>(), I.out.as<double>(), terms);
  SF_CUDA(cudaMemcpyAsync(grad, I.out.p, n * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  return value;
}

double RegularizersGpu::evaluate_device(const double* d_theta, double* d_grad, std::array<double, 2>* terms) {
  Impl& I = *impl_;
  cudaStream_t s = I.stream;
  const int nt = I.nt, ne = I.ne, nb = blocks(std::max(std::max(nt, ne), 1));
  RegArgs a;
  a.nt = nt;
  a.ne = ne;
  a.fix = I.obj->delta_fix();
  a.cur = I.obj->delta_cur();
  a.theta = reinterpret_cast<const Vec2*>(d_theta);
  a.theta_bar = I.theta_bar.as<Vec2>();
  a.z = I.z.as<Vec2>();
  a.elem = I.elem.as<int>();
  a.off = I.off.as<int>();
  a.slots = I.slots.as<int>();
  a.w = I.w.as<double>();
  a.val_cur = I.val_cur.as<double>();
  a.slot = I.slot.as<Vec2>();
  a.grad = reinterpret_cast<Vec2*>(d_grad);
  a.part = I.out.as<double>() + 2 * size_t(nt);  // after the host path's gradient
  if (a.cur != 0 && ne) k_curve<<<blocks(ne), kBlock, 0, s>>>(a);
  k_reg_gather<<<nb, kBlock, 0, s>>>(a);
  SF_CUDA(cudaGetLastError());
  const std::array<double, 2> t = sum_partials<2>(a.part, nb, I.host, s);
  if (terms) *terms = t;
  return t[0] + t[1];
}

void RegularizersGpu::apply_preconditioner(const Vec2* g, Vec2* out) {
  Impl& I = *impl_;
  cudaStream_t s = I.stream;
  const size_t n = 2 * size_t(I.nt);
  upload(I.gin, reinterpret_cast<const double*>(g), n, s);
  apply_preconditioner_device(I.gin.as<double>(), I.gout.as<double>());
  SF_CUDA(cudaMemcpyAsync(out, I.gout.p, n * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
}

void RegularizersGpu::apply_preconditioner_device(const double* d_g, double* d_out) {
  Impl& I = *impl_;
  // Every row reads all of g.
  if (d_out == d_g) throw std::invalid_argument("apply_preconditioner_device: out must not overwrite g");
  cudaStream_t s = I.stream;
  const size_t n = 2 * size_t(I.nt);
  if (I.built != I.pre->preconditioner_version()) {
    // P changed (or was never built): the CPU's factorization, then its inverse, column by column.
    std::vector<double> h(n * n);
    I.pre->dense_inverse(h.data());
    upload(I.inv, h.data(), h.size(), s);
    SF_CUDA(cudaStreamSynchronize(s));
    I.built = I.pre->preconditioner_version();
    ++I.builds;
  }
  DenseRows rows = I.rows;
  rows.in = d_g;
  rows.out = d_out;
  launch_dense_rows<1>(rows, s);
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaStreamSynchronize(s));
}

size_t RegularizersGpu::device_bytes() const { return impl_->inv.bytes; }

long RegularizersGpu::inverse_builds() const { return impl_->builds; }

int RegularizersGpu::n_theta() const { return impl_->nt; }

struct SeamLengthGpu::Impl {
  const opt::SeamLength* seam = nullptr;
  cudaStream_t stream = nullptr;
  int nt = 0, ns = 0;
  DevBuf theta, seg, rho, off, slots, val, slot, out;  // out: the host path's gradient, then the block partials
  std::vector<double> host;  // block partials
  ~Impl() {
    if (stream) cudaStreamDestroy(stream);
  }
};

SeamLengthGpu::SeamLengthGpu(const opt::SeamLength& seam) : impl_(new Impl) {
  Impl& I = *impl_;
  I.seam = &seam;
  I.nt = seam.n_theta();
  I.ns = int(seam.segments().size());
  SF_CUDA(cudaStreamCreateWithFlags(&I.stream, cudaStreamNonBlocking));
  cudaStream_t s = I.stream;
  const opt::Gather& G = seam.segment_gather();
  upload(I.seg, I.ns ? seam.segments()[0].data() : nullptr, 4 * size_t(I.ns), s);
  upload(I.rho, seam.ratios().data(), size_t(I.ns), s);
  upload(I.off, G.offsets.data(), G.offsets.size(), s);
  upload(I.slots, G.slots.data(), G.slots.size(), s);
  I.theta.reserve(2 * size_t(std::max(I.nt, 1)) * sizeof(double));
  I.val.reserve(size_t(std::max(I.ns, 1)) * sizeof(double));
  I.slot.reserve(8 * size_t(std::max(I.ns, 1)) * sizeof(double));
  const int nb = blocks(std::max(std::max(I.nt, I.ns), 1));
  I.out.reserve((2 * size_t(I.nt) + size_t(nb)) * sizeof(double));
  SF_CUDA(cudaStreamSynchronize(s));
}

SeamLengthGpu::~SeamLengthGpu() = default;

int SeamLengthGpu::n_theta() const { return impl_->nt; }

double SeamLengthGpu::evaluate(const Vec2* theta, Vec2* grad) {
  Impl& I = *impl_;
  cudaStream_t s = I.stream;
  const size_t n = 2 * size_t(I.nt);
  upload(I.theta, reinterpret_cast<const double*>(theta), n, s);
  const double value = evaluate_device(I.theta.as<double>(), I.out.as<double>());
  SF_CUDA(cudaMemcpyAsync(grad, I.out.p, n * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  return value;
}

double SeamLengthGpu::evaluate_device(const double* d_theta, double* d_grad) {
  Impl& I = *impl_;
  cudaStream_t s = I.stream;
  const int nt = I.nt, ns = I.ns, nb = blocks(std::max(std::max(nt, ns), 1));
  I.seam->count_evaluation();
  SeamArgs a;
  a.nt = nt;
  a.ns = ns;
  a.k = I.seam->delta_seam();
  a.theta = reinterpret_cast<const Vec2*>(d_theta);
  a.seg = I.seg.as<int>();
  a.off = I.off.as<int>();
  a.slots = I.slots.as<int>();
  a.rho = I.rho.as<double>();
  a.val = I.val.as<double>();
  a.slot = I.slot.as<Vec2>();
  a.grad = reinterpret_cast<Vec2*>(d_grad);
  a.part = I.out.as<double>() + 2 * size_t(nt);  // after the host path's gradient
  if (ns) k_seam<<<blocks(ns), kBlock, 0, s>>>(a);
  k_seam_gather<<<nb, kBlock, 0, s>>>(a);
  SF_CUDA(cudaGetLastError());
  return sum_partials<1>(a.part, nb, I.host, s)[0];
}

}  // namespace seamfit::cuda
