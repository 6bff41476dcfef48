#include "sim/dfdp_gpu.hpp"

#include <cuda_runtime.h>

#include <vector>

#include "device/dev_buffer.cuh"
#include "sim/dfdp.hpp"
#include "sim/sim_iteration.cuh"
#include "sim/simulator.hpp"
#include "sim/terms/bending.hpp"
#include "sim/terms/spring.hpp"

namespace seamfit::cuda {

namespace {

constexpr int kBlock = 128;

struct Arrays {
  int n = 0, E = 0, T = 0, H = 0;  // the elements whose terms are on
  DeviceRest d;                     // the pattern, rest state and topology
  const double *x = nullptr, *lam = nullptr;
  double *sp = nullptr, *hp = nullptr, *tp = nullptr, *wv = nullptr, *out = nullptr;
  double Y = 0, kb = 0, rho3 = 0, sb = 0, dhat = 0, m_floor = 0;
  Vec3 gv{0, 0, 0};
  bool bar = false, smooth = true;
  SdfGridView sdf;
};

__global__ void k_springs(Arrays a) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= a.E) return;
  if (a.d.L_floored[e]) {
    a.sp[2 * e] = a.sp[2 * e + 1] = 0;
    return;
  }
  const int i = a.d.spring_v[2 * e], j = a.d.spring_v[2 * e + 1];
  sim::patch_spring_dfdp_T(load3(a.x, i), load3(a.x, j), load3(a.lam, i), load3(a.lam, j), a.d.p[2 * i],
                           a.d.p[2 * i + 1], a.d.p[2 * j], a.d.p[2 * j + 1], a.d.rest_L[e], a.d.shirring[e], a.Y,
                           a.sp + 2 * e);
}

__global__ void k_hinges(Arrays a) {
  const int h = blockIdx.x * blockDim.x + threadIdx.x;
  if (h >= a.H) return;
  double pp[8];
  Vec3 xx[4], ll[4];
  for (int k = 0; k < 4; ++k) {
    const int v = a.d.hinge_v[4 * h + k];
    pp[2 * k] = a.d.p[2 * v];
    pp[2 * k + 1] = a.d.p[2 * v + 1];
    xx[k] = load3(a.x, v);
    ll[k] = load3(a.lam, v);
  }
  sim::hinge_dfdp_T(pp, xx, ll, a.kb, a.hp + 8 * h);
}

__global__ void k_weights(Arrays a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= a.n) return;
  const bool b = a.bar && a.d.mass[v] >= a.m_floor;
  const SdfSample s = b ? sim::barrier_field(a.sdf, a.smooth, load3(a.x, v)) : SdfSample{};
  a.wv[v] = sim::dfdp_mass_weight(a.gv, load3(a.lam, v), b, s, a.sb, a.dhat);
}

__global__ void k_triangles(Arrays a) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= a.T) return;
  sim::dfdp_triangle(a.d.p, a.d.tris + 3 * t, a.wv, a.rho3, a.tp + 6 * t);
}

__global__ void k_gather(Arrays a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= a.n) return;
  const DeviceRest& d = a.d;
  sim::dfdp_gather(v, d.vs_ptr, d.vs_idx, a.Y > 0 ? a.sp : nullptr, d.vh_ptr, d.vh_idx, a.kb > 0 ? a.hp : nullptr,
                   d.vt_ptr, d.vt_idx, a.rho3 != 0 ? a.tp : nullptr, a.out + 2 * v);
}

int blocks(int n) { return (n + kBlock - 1) / kBlock; }

}  // namespace

struct DfdpGpu::Impl {
  SimGpu* gpu = nullptr;
  cudaStream_t stream = nullptr;
  DevBuf x, lam, sp, hp, tp, wv, out;  // per call
};

DfdpGpu::DfdpGpu(SimGpu& gpu) : impl_(new Impl) {
  impl_->gpu = &gpu;
  impl_->stream = static_cast<cudaStream_t>(gpu.stream_handle());
}

DfdpGpu::~DfdpGpu() = default;

void DfdpGpu::apply(const double* x, const double* lam, double* out) {
  Impl& I = *impl_;
  const int n = I.gpu->device_rest().n;
  upload(I.x, x, 3 * size_t(n), I.stream);
  upload(I.lam, lam, 3 * size_t(n), I.stream);
  I.out.reserve(2 * size_t(n) * sizeof(double));
  apply_device(I.x.as<double>(), I.lam.as<double>(), I.out.as<double>());
  SF_CUDA(cudaMemcpyAsync(out, I.out.p, 2 * size_t(n) * sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
}

void DfdpGpu::apply_device(const double* d_x, const double* d_lam, double* d_out) {
  Impl& I = *impl_;
  // The pattern, rest state and topology as the GPU simulator holds them (its last sync()).
  const DeviceRest d = I.gpu->device_rest();
  const sim::SimParams& P = I.gpu->simulator().params();
  const int n = d.n, E = d.n_springs, T = d.n_tris, H = d.n_hinges;
  I.sp.reserve(2 * size_t(E) * sizeof(double));
  I.hp.reserve(8 * size_t(H) * sizeof(double));
  I.tp.reserve(6 * size_t(T) * sizeof(double));
  I.wv.reserve(size_t(n) * sizeof(double));

  Arrays a;
  a.n = n;
  a.E = P.stretch_Y > 0 ? E : 0;
  a.H = P.bend_kb > 0 ? H : 0;
  a.d = d;
  a.x = d_x;
  a.lam = d_lam;
  a.sp = I.sp.as<double>();
  a.hp = I.hp.as<double>();
  a.tp = I.tp.as<double>();
  a.wv = I.wv.as<double>();
  a.out = d_out;
  a.Y = P.stretch_Y;
  a.kb = P.bend_kb;
  a.gv = P.gravity;
  a.bar = I.gpu->simulator().barrier_on();
  // As the CPU: the mass terms only where there is gravity or a barrier.
  const bool mass_terms = P.density > 0 && (norm2(P.gravity) > 0 || a.bar);
  a.rho3 = mass_terms ? P.density / 3.0 : 0.0;
  a.T = mass_terms ? T : 0;
  a.sb = P.mu * P.barrier_length * sim::kG0;
  a.dhat = P.barrier_distance;
  a.m_floor = I.gpu->simulator().arrays().m_floor;
  a.smooth = P.barrier_smooth;
  if (a.bar) {
    // The body field in device memory, as the GPU simulator holds it.
    if (I.gpu->options().float_rest)
      a.sdf = static_cast<const DevModel<float>*>(I.gpu->device_model())->sdf;
    else
      a.sdf = static_cast<const DevModel<double>*>(I.gpu->device_model())->sdf;
  }
  if (a.E) k_springs<<<blocks(a.E), kBlock, 0, I.stream>>>(a);
  if (a.H) k_hinges<<<blocks(a.H), kBlock, 0, I.stream>>>(a);
  if (a.T) {
    k_weights<<<blocks(n), kBlock, 0, I.stream>>>(a);
    k_triangles<<<blocks(a.T), kBlock, 0, I.stream>>>(a);
  }
  k_gather<<<blocks(n), kBlock, 0, I.stream>>>(a);
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaStreamSynchronize(I.stream));
}

}  // namespace seamfit::cuda
