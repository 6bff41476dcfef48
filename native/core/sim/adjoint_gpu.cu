// GPU adjoint solve (see adjoint_gpu.hpp, docs/gpu_backend.md "The adjoint on the GPU").
//
// Per state: one kernel stores every spring's Hessian block, one stores each
// vertex's own block and its preconditioner block (PSD) and sums |diag H| for
// the shift, a one-block kernel sets the shift, and one inverts the shifted
// preconditioner blocks. Per MINRES iteration four kernels: the stored-block
// product with the lam update of the previous iteration folded in, the
// reduction of alfa, the Lanczos vector update with the preconditioner, and
// the reduction of beta with the scalar rotation (sim/minres.hpp). Sums are
// reduced in a fixed order, so a solve is deterministic run to run.
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#pragma nv_diag_suppress 20012

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <vector>

#include "sim/adjoint_gpu.hpp"
#include "device/dev_buffer.cuh"
#include "sim/solve_messages.hpp"
#include "sim/minres.hpp"
#include "sim/sim_iteration.cuh"

namespace seamfit::cuda {

using sim::MinresState;

namespace {

constexpr int kRedThreads = 256;
constexpr int kPersistentThreads = 128;

// Everything the iteration kernels touch besides the model (3n doubles each
// unless said otherwise).
struct Vecs {
  int n = 0;
  const double* g = nullptr;
  double *lam = nullptr, *r1 = nullptr, *r2 = nullptr, *y = nullptr, *v = nullptr, *t = nullptr;
  double *w = nullptr, *w2 = nullptr;
  Sym3 *Hs = nullptr, *Hown = nullptr, *Minv = nullptr;  // per spring, per vertex, per vertex
  double* part = nullptr;                                 // per-block partial sums
  MinresState* st = nullptr;
};

// Q partial sums per block, reduced by one block in a fixed order.
template <int Q>
__device__ void reduce_fixed(const double* part, int nb, double (&out)[Q]) {
  __shared__ double sh[Q][kRedThreads];
  const int t = threadIdx.x, nt = blockDim.x;
  for (int q = 0; q < Q; ++q) {
    double a = 0;
    // __ldcg: other blocks wrote these; read them from L2, never a stale L1 line.
    for (int b = t; b < nb; b += nt) a += __ldcg(part + Q * b + q);
    sh[q][t] = a;
  }
  tree_sum(sh);
  for (int q = 0; q < Q; ++q) out[q] = sh[q][0];
}

template <class R>
__global__ void k_spring_blocks(DevModel<R> m, const double* __restrict__ x, Sym3* __restrict__ Hs, int n_springs,
                                int psd) {
  const int sp = blockIdx.x * blockDim.x + threadIdx.x;
  if (sp < n_springs) Hs[sp] = spring_hess_block(m, x, sp, psd != 0);
}

// Own block, preconditioner block (PSD: the simulator's Jacobi block D) and
// the vertex's |diag H| sum for the shift.
template <class R>
__global__ void k_vertex_blocks(DevModel<R> m, const double* __restrict__ x, Vecs a, int psd) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double s[1] = {0};
  if (v < m.n) {
    const Sym3 own = own_hess_block(m, x, v, psd != 0);
    Sym3 diag = own, P = psd ? own : own_hess_block(m, x, v, true);
    if (m.Y > 0)
      for (int k = m.vs_ptr[v]; k < m.vs_ptr[v + 1]; ++k) {
        const int sp = m.vs_idx[k] >> 1;
        diag += a.Hs[sp];
        P += psd ? a.Hs[sp] : spring_hess_block(m, x, sp, true);
      }
    if (m.kb > 0) {
      const Sym3 qb = sim::sym3_identity(m.kb * double(m.Q[m.nbr_ptr[v] + m.self_slot[v]]));
      diag += qb;
      P += qb;
    }
    a.Hown[v] = own;
    a.Minv[v] = P;  // inverted by k_precond once the shift is known
    s[0] = fabs(diag.xx) + fabs(diag.yy) + fabs(diag.zz);
  }
  block_sum<1>(s, a.part + blockIdx.x);
}

__global__ void __launch_bounds__(kRedThreads) k_shift(Vecs a, int nb, double shift_rel) {
  double s[1];
  reduce_fixed<1>(a.part, nb, s);
  if (threadIdx.x == 0) a.st->shift = a.n > 0 ? shift_rel * s[0] / (3.0 * a.n) : 0.0;
}

// Shift the own blocks; invert the shifted preconditioner blocks (by columns,
// with the Jacobi step's fallback for a block that is not positive definite).
__global__ void k_precond(Vecs a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= a.n) return;
  const Sym3 sI = sim::sym3_identity(a.st->shift);
  a.Hown[v] += sI;
  const Sym3 P = a.Minv[v] + sI;
  const Vec3 c0 = sim::jacobi_direction(P, make_vec3(1, 0, 0), 1.0);
  const Vec3 c1 = sim::jacobi_direction(P, make_vec3(0, 1, 0), 1.0);
  const Vec3 c2 = sim::jacobi_direction(P, make_vec3(0, 0, 1), 1.0);
  a.Minv[v] = Sym3{c0.x, c1.y, c2.z, 0.5 * (c0.y + c1.x), 0.5 * (c0.z + c2.x), 0.5 * (c1.z + c2.y)};
}

// H u at vertex v from the stored blocks (the shift is in the own block).
template <class R>
__device__ Vec3 stored_hess_vec(const DevModel<R>& m, const Vecs& a, const double* u, int v) {
  return hess_vec_gather(m, u, v, [&](int sp) { return a.Hs[sp]; }, a.Hown[v]);
}

// The pending lam update of the last iteration at vertex v.
__device__ void apply_update(const Vecs& a, const MinresState& s, int v) {
  const Vec3 wo = load3(a.w, v), w2o = load3(a.w2, v);
  const Vec3 wn = s.denom * (load3(a.v, v) - s.oldeps * w2o - s.delta * wo);
  store3(a.w2, v, wo);
  store3(a.w, v, wn);
  store3(a.lam, v, load3(a.lam, v) + s.phi * wn);
}

// r = g - H lam; r1 = r2 = r; y = M^-1 r; w = w2 = 0. Partials: r.y, g.M^-1 g, g.g.
template <class R>
__global__ void k_init(DevModel<R> m, Vecs a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double s[3] = {0, 0, 0};
  if (v < a.n) {
    const Vec3 g = load3(a.g, v);
    const Vec3 r = g - stored_hess_vec(m, a, a.lam, v);
    const Vec3 y = a.Minv[v] * r;
    store3(a.r1, v, r);
    store3(a.r2, v, r);
    store3(a.y, v, y);
    store3(a.w, v, make_vec3(0, 0, 0));
    store3(a.w2, v, make_vec3(0, 0, 0));
    store3(a.v, v, make_vec3(0, 0, 0));
    s[0] = dot(r, y);
    s[1] = dot(g, a.Minv[v] * g);
    s[2] = dot(g, g);
  }
  block_sum<3>(s, a.part + 3 * blockIdx.x);
}

__global__ void __launch_bounds__(kRedThreads) k_start(Vecs a, int nb, double tol, int max_it) {
  double s[3];
  reduce_fixed<3>(a.part, nb, s);
  if (threadIdx.x == 0) {
    MinresState st = *a.st;
    st.tol = tol;
    st.max_it = max_it;
    st.gnorm2 = s[2];
    sim::minres_start(st, s[0], s[1]);
    *a.st = st;
  }
}

// The two vector phases of a MINRES iteration at vertex v (sim/minres.hpp),
// shared by the kernel-per-phase path and the persistent kernel.
//
// Phase A: the last iteration's pending lam update, then t = H v - (beta/oldb) r1
// with v = y / beta. Returns v.t (alfa's share).
template <class R>
__device__ double lanczos_vertex(const DevModel<R>& m, const Vecs& a, const MinresState& s, int v) {
  if (s.pending) apply_update(a, s, v);
  const double ib = 1.0 / s.beta;
  const Vec3 vn = ib * load3(a.y, v);
  Vec3 t = ib * stored_hess_vec(m, a, a.y, v);
  if (s.oldb > 0) t -= (s.beta / s.oldb) * load3(a.r1, v);
  store3(a.v, v, vn);
  store3(a.t, v, t);
  return dot(vn, t);
}

// Phase B: t -= (alfa/beta) r2; r1 = r2; r2 = t; y = M^-1 r2. Returns r2.y.
__device__ double precondition_vertex(const Vecs& a, const MinresState& s, int v) {
  const Vec3 r2 = load3(a.r2, v);
  const Vec3 t = load3(a.t, v) - (s.alfa / s.beta) * r2;
  const Vec3 y = a.Minv[v] * t;
  store3(a.r1, v, r2);
  store3(a.r2, v, t);
  store3(a.y, v, y);
  return dot(t, y);
}

template <class R>
__global__ void k_lanczos(DevModel<R> m, Vecs a) {
  const MinresState s = *a.st;
  if (s.done) return;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double p[1] = {v < a.n ? lanczos_vertex(m, a, s, v) : 0.0};
  block_sum<1>(p, a.part + blockIdx.x);
}

__global__ void __launch_bounds__(kRedThreads) k_alfa(Vecs a, int nb) {
  if (a.st->done) return;
  double s[1];
  reduce_fixed<1>(a.part, nb, s);
  __syncthreads();  // every thread has read done before thread 0 writes the state
  if (threadIdx.x == 0) {
    a.st->alfa = s[0];
    a.st->pending = 0;
  }
}

__global__ void k_precondition(Vecs a) {
  const MinresState s = *a.st;
  if (s.done) return;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double p[1] = {v < a.n ? precondition_vertex(a, s, v) : 0.0};
  block_sum<1>(p, a.part + blockIdx.x);
}

__global__ void __launch_bounds__(kRedThreads) k_rotate(Vecs a, int nb) {
  if (a.st->done) return;
  double s[1];
  reduce_fixed<1>(a.part, nb, s);
  __syncthreads();
  if (threadIdx.x == 0) {
    MinresState st = *a.st;
    sim::minres_rotate(st, s[0]);
    *a.st = st;
  }
}

// `iters` MINRES iterations in one cooperative launch: each block keeps the
// scalar state in shared memory and walks its vertices grid-stride; a grid
// barrier after each vector phase, after which every block reduces all the
// blocks' partial sums itself (same order in every block, so all copies of the
// state stay identical) instead of a one-block kernel doing it. Two barriers
// per iteration instead of four launches. partA / partB: one slot per block
// each, so a phase never overwrites sums another block may still be reading.
template <class R>
__global__ void __launch_bounds__(kPersistentThreads) k_minres_persistent(DevModel<R> m, Vecs a, double* partB, int iters) {
  namespace cg = cooperative_groups;
  cg::grid_group grid = cg::this_grid();
  __shared__ MinresState s;
  const int G = gridDim.x, stride = G * blockDim.x;
  if (threadIdx.x == 0) s = *a.st;
  __syncthreads();
  for (int it = 0; it < iters && !s.done; ++it) {
    double p[1] = {0};
    for (int v = blockIdx.x * blockDim.x + threadIdx.x; v < a.n; v += stride) p[0] += lanczos_vertex(m, a, s, v);
    block_sum<1>(p, a.part + blockIdx.x);
    grid.sync();
    double r[1];
    reduce_fixed<1>(a.part, G, r);
    if (threadIdx.x == 0) {
      s.alfa = r[0];
      s.pending = 0;
    }
    __syncthreads();
    p[0] = 0;
    for (int v = blockIdx.x * blockDim.x + threadIdx.x; v < a.n; v += stride) p[0] += precondition_vertex(a, s, v);
    block_sum<1>(p, partB + blockIdx.x);
    grid.sync();
    reduce_fixed<1>(partB, G, r);
    if (threadIdx.x == 0) sim::minres_rotate(s, r[0]);
    __syncthreads();
  }
  if (blockIdx.x == 0 && threadIdx.x == 0) *a.st = s;
}

__global__ void k_finish(Vecs a) {
  const MinresState s = *a.st;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < a.n && s.pending) apply_update(a, s, v);
}

// |g - H lam|^2 partials.
template <class R>
__global__ void k_residual(DevModel<R> m, Vecs a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double p[1] = {0};
  if (v < a.n) {
    const Vec3 r = load3(a.g, v) - stored_hess_vec(m, a, a.lam, v);
    p[0] = dot(r, r);
  }
  block_sum<1>(p, a.part + blockIdx.x);
}

__global__ void __launch_bounds__(kRedThreads) k_residual_sum(Vecs a, int nb) {
  double s[1];
  reduce_fixed<1>(a.part, nb, s);
  if (threadIdx.x == 0) {
    a.st->rnorm2 = s[0];
    a.st->pending = 0;
  }
}

}  // namespace

struct AdjointGpu::Impl {
  SimGpu* gpu = nullptr;
  cudaStream_t stream = nullptr;
  int n = 0, n_springs = 0, block = 128, nb = 0;
  DevBuf x, g, lam, r1, r2, y, v, t, w, w2, Hs, Hown, Minv, part, partB, st;
  int coop_blocks = 0;  // blocks of the persistent kernel (0: no cooperative launch here)
  MinresState* snap = nullptr;  // pinned
  bool have_state = false;
  // The graph of a batch and what it was captured with.
  cudaGraphExec_t graph = nullptr;
  int graph_batch = 0;
  alignas(8) unsigned char graph_model[sizeof(DevModel<double>)] = {};

  ~Impl() {
    if (graph) cudaGraphExecDestroy(graph);
    if (snap) cudaFreeHost(snap);
  }

  Vecs vecs() const {
    Vecs a;
    a.n = n;
    a.g = g.as<double>();
    a.lam = lam.as<double>();
    a.r1 = r1.as<double>();
    a.r2 = r2.as<double>();
    a.y = y.as<double>();
    a.v = v.as<double>();
    a.t = t.as<double>();
    a.w = w.as<double>();
    a.w2 = w2.as<double>();
    a.Hs = Hs.as<Sym3>();
    a.Hown = Hown.as<Sym3>();
    a.Minv = Minv.as<Sym3>();
    a.part = part.as<double>();
    a.st = st.as<MinresState>();
    return a;
  }

  template <class F>
  void with_model(F&& fn) {
    if (gpu->options().float_rest) fn(*static_cast<const DevModel<float>*>(gpu->device_model()));
    else fn(*static_cast<const DevModel<double>*>(gpu->device_model()));
  }

  void launch_iteration() {
    const Vecs a = vecs();
    with_model([&](const auto& m) {
      using M = std::decay_t<decltype(m)>;
      using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
      k_lanczos<R><<<nb, block, 0, stream>>>(m, a);
    });
    k_alfa<<<1, kRedThreads, 0, stream>>>(a, nb);
    k_precondition<<<nb, block, 0, stream>>>(a);
    k_rotate<<<1, kRedThreads, 0, stream>>>(a, nb);
    SF_CUDA(cudaGetLastError());
  }

  void launch_batch(int batch) {
    // The model is passed by value into the kernels: a graph captured with
    // another model (after a sync() of the simulator) is stale.
    unsigned char now[sizeof(DevModel<double>)] = {};
    std::memcpy(now, gpu->device_model(),
                gpu->options().float_rest ? sizeof(DevModel<float>) : sizeof(DevModel<double>));
    if (!graph || graph_batch != batch || std::memcmp(now, graph_model, sizeof now) != 0) {
      if (graph) cudaGraphExecDestroy(graph);
      graph = nullptr;
      cudaGraph_t gr;
      SF_CUDA(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal));
      for (int i = 0; i < batch; ++i) launch_iteration();
      SF_CUDA(cudaStreamEndCapture(stream, &gr));
      const cudaError_t e = cudaGraphInstantiate(&graph, gr, 0);
      cudaGraphDestroy(gr);
      check(e, "cudaGraphInstantiate");
      graph_batch = batch;
      std::memcpy(graph_model, now, sizeof now);
    }
    SF_CUDA(cudaGraphLaunch(graph, stream));
  }

  // `iters` iterations in one cooperative launch of the persistent kernel.
  void launch_persistent(int iters) {
    Vecs a = vecs();
    double* pb = partB.as<double>();
    with_model([&](const auto& m) {
      using M = std::decay_t<decltype(m)>;
      using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
      M mm = m;
      void* args[] = {&mm, &a, &pb, &iters};
      SF_CUDA(cudaLaunchCooperativeKernel(reinterpret_cast<void*>(&k_minres_persistent<R>), dim3(coop_blocks),
                                          dim3(kPersistentThreads), args, 0, stream));
    });
  }

  MinresState read_state() {
    SF_CUDA(cudaMemcpyAsync(snap, st.p, sizeof(MinresState), cudaMemcpyDeviceToHost, stream));
    SF_CUDA(cudaStreamSynchronize(stream));
    return *snap;
  }
};

AdjointGpu::AdjointGpu(SimGpu& gpu) : impl_(new Impl) {
  Impl& I = *impl_;
  I.gpu = &gpu;
  I.stream = static_cast<cudaStream_t>(gpu.stream_handle());
  const sim::SimArrays arr = gpu.simulator().arrays();
  I.n = arr.n;
  I.n_springs = arr.n_springs;
  I.block = gpu.options().block;
  I.nb = (I.n + I.block - 1) / I.block;
  const size_t n3 = 3 * size_t(I.n) * sizeof(double);
  for (DevBuf* b : {&I.x, &I.g, &I.lam, &I.r1, &I.r2, &I.y, &I.v, &I.t, &I.w, &I.w2}) b->reserve(n3);
  I.Hs.reserve(size_t(I.n_springs) * sizeof(Sym3));
  I.Hown.reserve(size_t(I.n) * sizeof(Sym3));
  I.Minv.reserve(size_t(I.n) * sizeof(Sym3));
  // The persistent kernel needs all its blocks resident at once: as many as fit, at
  // most one per 128 vertices.
  int dev = 0, coop = 0, sms = 0, per_sm = 0;
  SF_CUDA(cudaGetDevice(&dev));
  SF_CUDA(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, dev));
  SF_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
  if (coop) {
    if (gpu.options().float_rest)
      SF_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_minres_persistent<float>, kPersistentThreads, 0));
    else
      SF_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_minres_persistent<double>, kPersistentThreads, 0));
    const int want = (I.n + kPersistentThreads - 1) / kPersistentThreads;
    I.coop_blocks = std::max(1, std::min(want, per_sm * sms));
    if (per_sm == 0) I.coop_blocks = 0;
  }
  I.part.reserve(size_t(std::max({I.nb, I.coop_blocks, 1})) * 3 * sizeof(double));
  I.partB.reserve(size_t(std::max(I.coop_blocks, 1)) * sizeof(double));
  I.st.reserve(sizeof(MinresState));
  SF_CUDA(cudaMallocHost(&I.snap, sizeof(MinresState)));
  *I.snap = MinresState();
  SF_CUDA(cudaMemcpyAsync(I.st.p, I.snap, sizeof(MinresState), cudaMemcpyHostToDevice, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
}

AdjointGpu::~AdjointGpu() = default;

void AdjointGpu::set_state(const double* x, bool psd, double shift_rel) {
  Impl& I = *impl_;
  // Host or device memory: the runtime tells them apart (unified addressing).
  if (I.gpu->simulator().arrays().n != I.n) throw CudaError("the simulator's topology changed under its adjoint");
  SF_CUDA(cudaMemcpyAsync(I.x.p, x, 3 * size_t(I.n) * sizeof(double), cudaMemcpyDefault, I.stream));
  const Vecs a = I.vecs();
  const int nbs = (I.n_springs + I.block - 1) / I.block;
  I.with_model([&](const auto& m) {
    using M = std::decay_t<decltype(m)>;
    using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
    if (I.n_springs > 0)
      k_spring_blocks<R><<<nbs, I.block, 0, I.stream>>>(m, I.x.as<double>(), I.Hs.as<Sym3>(), I.n_springs, psd);
    k_vertex_blocks<R><<<I.nb, I.block, 0, I.stream>>>(m, I.x.as<double>(), a, psd);
  });
  k_shift<<<1, kRedThreads, 0, I.stream>>>(a, I.nb, shift_rel);
  k_precond<<<I.nb, I.block, 0, I.stream>>>(a);
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaStreamSynchronize(I.stream));
  I.have_state = true;
}

void AdjointGpu::set_state_device(const double* d_x, bool psd, double shift_rel) { set_state(d_x, psd, shift_rel); }

AdjointReport AdjointGpu::solve(const double* g, double* lam, const AdjointSettings& s) {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const size_t n3 = 3 * size_t(I.n) * sizeof(double);
  if (!I.have_state) throw CudaError("AdjointGpu::solve called before set_state");
  // Into the buffers the captured graph reads, from host or device memory (device to
  // device: microseconds).
  SF_CUDA(cudaMemcpyAsync(I.g.p, g, n3, cudaMemcpyDefault, I.stream));
  SF_CUDA(cudaMemcpyAsync(I.lam.p, lam, n3, cudaMemcpyDefault, I.stream));
  AdjointReport r = minres(s, t0);
  SF_CUDA(cudaMemcpyAsync(lam, I.lam.p, n3, cudaMemcpyDefault, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  return r;
}

AdjointReport AdjointGpu::solve_device(const double* d_g, double* d_lam, const AdjointSettings& s) {
  return solve(d_g, d_lam, s);
}

AdjointReport AdjointGpu::minres(const AdjointSettings& s, std::chrono::steady_clock::time_point t0) {
  Impl& I = *impl_;
  const Vecs a = I.vecs();
  I.with_model([&](const auto& m) {
    using M = std::decay_t<decltype(m)>;
    using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
    k_init<R><<<I.nb, I.block, 0, I.stream>>>(m, a);
  });
  k_start<<<1, kRedThreads, 0, I.stream>>>(a, I.nb, s.tolerance, std::max(s.max_iterations, 1));
  SF_CUDA(cudaGetLastError());
  MinresState st = I.read_state();
  const int batch = std::max(s.batch, 1);
  const bool persistent = s.persistent && I.coop_blocks > 0;
  while (!st.done) {
    if (persistent) I.launch_persistent(batch);
    else I.launch_batch(batch);
    st = I.read_state();
  }
  k_finish<<<I.nb, I.block, 0, I.stream>>>(a);
  I.with_model([&](const auto& m) {
    using M = std::decay_t<decltype(m)>;
    using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
    k_residual<R><<<I.nb, I.block, 0, I.stream>>>(m, a);
  });
  k_residual_sum<<<1, kRedThreads, 0, I.stream>>>(a, I.nb);
  SF_CUDA(cudaGetLastError());
  const MinresState fin = I.read_state();

  AdjointReport r;
  r.iterations = fin.it;
  r.shift = fin.shift;
  r.estimate = fin.bnorm > 0 ? fin.phibar / fin.bnorm : 0.0;
  r.residual = fin.gnorm2 > 0 ? std::sqrt(fin.rnorm2 / fin.gnorm2) : std::sqrt(fin.rnorm2);
  r.converged = fin.status == sim::kMinresConverged;
  r.status = sim::minres_status_name(fin.status);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (fin.status == sim::kMinresConverged)
    r.message = sim::msg_converged(r.estimate, s.tolerance, fin.it, "MINRES iterations");
  else if (fin.status == sim::kMinresBudget)
    r.message = sim::msg_iteration_budget(r.estimate, s.tolerance, fin.it, "MINRES iterations");
  else
    r.message = "MINRES broke down after " + std::to_string(fin.it) +
                " iterations (the preconditioner is not positive definite or the values are not finite)";
  return r;
}

}  // namespace seamfit::cuda
