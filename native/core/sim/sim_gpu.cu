// CUDA backend of the quasistatic simulator (see sim_gpu.hpp, docs/gpu_backend.md).
//
// One iteration is three kernels: the step (block-Jacobi direction, Chebyshev
// combination, barrier-safe step, and the field sample at the new position),
// the evaluation of the new state (force, diagonal blocks, energy terms,
// per-block partial sums) and a one-block control kernel that reduces the
// partial sums in a fixed order and runs the solver's rules (energy checks,
// restarts, rho and omega, stopping). A batch of iterations is one CUDA graph
// launch; the host reads the control state
// once per batch, and after a stop the rest of the batch returns at once.
// Per-vertex work is a gather over CSR incidence lists: no atomics in the
// physics, and the sums are deterministic.
#include <cuda_runtime.h>

// Eigen (through simulator.hpp) marks defaulted members __host__ __device__.
#pragma nv_diag_suppress 20012

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <vector>

#include "device/dev_buffer.cuh"
#include "sim/rest_state.hpp"
#include "sim/sim_gpu.hpp"
#include "sim/sim_iteration.cuh"
#include "sim/solve_messages.hpp"

namespace seamfit::cuda {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kCtrlThreads = 256;
constexpr int kRestBlock = 128;

// ------------------------------------------------------------------ kernels

__device__ unsigned long long global_ns() {
  unsigned long long t;
  asm volatile("mov.u64 %0, %%globaltimer;" : "=l"(t));
  return t;
}

// Reduce the partial sums of an iteration into sums[kSums] with all threads of
// the block (a power of two, at most kCtrlThreads), in a fixed order, so the
// result does not depend on which block runs it. ps may be null (no step).
__device__ void reduce_parts(const double* pe, int nbe, const double* ps, int nbs, double* sums) {
  __shared__ double sh[kSums][kCtrlThreads];
  const int t = threadIdx.x, nt = blockDim.x;
  for (int q = 0; q < kSums; ++q) {
    double a = 0;
    // __ldcg: other blocks wrote these; read them from L2, never a stale L1 line.
    if (q <= kTerms) {
      for (int b = t; b < nbe; b += nt) a += __ldcg(pe + (kTerms + 1) * b + q);
    } else if (ps) {
      for (int b = t; b < nbs; b += nt) a += __ldcg(ps + 2 * b + (q - kTerms - 1));
    }
    sh[q][t] = a;
  }
  tree_sum(sh);
  if (t == 0)
    for (int q = 0; q < kSums; ++q) sums[q] = sh[q][0];
}

// D += D of the lane o apart (one butterfly stage).
__device__ __forceinline__ void shfl_add(Sym3& D, int o) {
  D.xx += __shfl_xor_sync(0xffffffffu, D.xx, o);
  D.yy += __shfl_xor_sync(0xffffffffu, D.yy, o);
  D.zz += __shfl_xor_sync(0xffffffffu, D.zz, o);
  D.xy += __shfl_xor_sync(0xffffffffu, D.xy, o);
  D.xz += __shfl_xor_sync(0xffffffffu, D.xz, o);
  D.yz += __shfl_xor_sync(0xffffffffu, D.yz, o);
}

// Everything the evaluation kernel of a solve needs besides the model.
struct EvalArgs {
  Ctrl* c = nullptr;            // null: a plain evaluation (k_sums reduces)
  const double* x = nullptr;
  double* f = nullptr;
  Sym3* D = nullptr;
  Sym3* Dsp = nullptr;          // the springs' share of D at the last refresh (Ctrl::reuse)
  SdfSample* S = nullptr;
  double* part_eval = nullptr;  // per block: six energy terms and |f|^2
};

// The solver's control step on the reduced sums, by one thread, on a local
// copy of the control state (one load and one store, not one per field).
__device__ void control_step(Ctrl* c, const double* sums, int new_cur, double* upd_norm, double* hist) {
  Ctrl cc = *c;
  const unsigned long long now = global_ns();
  if (cc.mode == kInit) cc.t0_ns = now;
  ctrl_update(cc, sums, new_cur, upd_norm, hist, 1e-9 * double(now - cc.t0_ns));
  *c = cc;
}

// Force, diagonal blocks and energy shares at x, L threads per vertex (more
// threads in flight, shorter dependent chains per thread); per-block partial
// sums. Sample: sample the barrier field here (plain evaluations); in a solve
// the step kernel has sampled it at x already, and this kernel, free of the
// sampling code, needs far fewer registers. In a solve k_ctrl then reduces every
// block's sums and runs the solver's control step.
// In a solve the springs' share of the blocks follows SolveSettings::
// precond_refresh as on the CPU: with c->reuse their Hessians are not computed
// and the share stored at the last refresh is read instead; a refresh stores it
// when a later evaluation may reuse it (precond_refresh > 1).
template <class R, int L, bool Sample>
__global__ void __launch_bounds__(256) k_eval(DevModel<R> m, EvalArgs a) {
  Ctrl* c = a.c;
  if (c && c->done) return;
  constexpr bool known = !Sample;
  // The same for every thread of the launch: branches on them do not diverge.
  // Plain evaluations (Sample) neither read nor store the springs' share.
  const bool reuse = !Sample && c && c->reuse;
  const bool keep = !Sample && c && !reuse && c->precond_refresh > 1;
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int v = t / L, lane = t % L;
  const bool active = v < m.n;
  Vec3 g = make_vec3(0, 0, 0);
  Sym3 Dv = sim::sym3_zero(), Dsp = sim::sym3_zero();
  double e[kTerms] = {0, 0, 0, 0, 0, 0};
  SdfSample s;
  s.phi = 0;
  s.grad = make_vec3(0, 0, 0);
  if (active) {
    if (m.bar && known && lane == 0) s = a.S[v];
    if (reuse && lane == 0) Dsp = a.Dsp[v];
    eval_vertex_part(m, a.x, v, lane, L, known, !reuse, s, g, Dsp, Dv, e);
  }
  // Sum the lanes of a vertex (a butterfly: every lane ends with the total).
  // Reusing, the other lanes hold no share of the block: lane 0 has it all.
#pragma unroll
  for (int o = 1; o < L; o <<= 1) {
    g.x += __shfl_xor_sync(0xffffffffu, g.x, o);
    g.y += __shfl_xor_sync(0xffffffffu, g.y, o);
    g.z += __shfl_xor_sync(0xffffffffu, g.z, o);
    if (!reuse) shfl_add(Dv, o);
    if (keep) shfl_add(Dsp, o);
#pragma unroll
    for (int q = 0; q < kTerms; ++q) e[q] += __shfl_xor_sync(0xffffffffu, e[q], o);
  }
  double acc[kTerms + 1];
#pragma unroll
  for (int q = 0; q <= kTerms; ++q) acc[q] = 0;
  if (active && lane == 0) {
    const Vec3 fv = -g;
    if (Sample && m.bar && a.S) a.S[v] = s;
    store3(a.f, v, fv);
    a.D[v] = Dv;
    if (keep) a.Dsp[v] = Dsp;
#pragma unroll
    for (int q = 0; q < kTerms; ++q) acc[q] = e[q];
    acc[kTerms] = norm2(fv);
  }
  block_sum<kTerms + 1>(acc, a.part_eval + (kTerms + 1) * blockIdx.x);
}

// The control step: one block reduces the evaluation's and the step's partial sums.
__global__ void __launch_bounds__(kCtrlThreads) k_ctrl(Ctrl* c, const double* pe, int nbe, const double* ps, int nbs,
                                                      int new_cur, double* upd_norm, double* hist) {
  if (c->done) return;
  __shared__ double sums[kSums];
  reduce_parts(pe, nbe, ps, nbs, sums);
  if (threadIdx.x == 0) control_step(c, sums, new_cur, upd_norm, hist);
}

// The step from cur (x_k) with prev (x_{k-1}); the new state goes to prev.
// Restore modes copy the checkpoint into both; they and the start (kInit)
// sample the barrier field at the state the evaluation reads next (prev).
// Partial sums: |dx|^2 and the count of dropped vertex steps.
template <class R>
__global__ void __launch_bounds__(256) k_step(DevModel<R> m, const Ctrl* c, double* __restrict__ cur,
                                               double* __restrict__ prev, double* __restrict__ ck,
                                               const double* __restrict__ f, const Sym3* __restrict__ D,
                                               SdfSample* __restrict__ S, double* __restrict__ part) {
  if (c->done) return;
  const int mode = c->mode;
  const double far = c->far;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double acc[2] = {0, 0};
  if (v < m.n) {
    if (mode == kRestore || mode == kFinalRestore) {
      const Vec3 xk = load3(ck, v);
      store3(cur, v, xk);
      store3(prev, v, xk);
      if (m.bar) S[v] = sim::barrier_field(m.sdf, m.smooth != 0, xk);
    } else if (mode == kInit) {
      if (m.bar) S[v] = sim::barrier_field(m.sdf, m.smooth != 0, load3(prev, v));
    } else if (mode == kStep) {
      const Vec3 xo = load3(cur, v);
      if (c->save_ck) store3(ck, v, xo);
      const Vec3 d = sim::jacobi_direction(D[v], load3(f, v), c->alpha);
      acc[0] = norm2(d);
      SdfSample s;
      if (m.bar) s = S[v];
      Vec3 xn;
      // far > 0 (SolveSettings::far_bound): a step that provably ends beyond the
      // barrier's reach keeps a bound in S instead of a sample, as on the CPU;
      // the bound stays with the vertex (S) until a restore samples it again.
      if (sim::chebyshev_safe_step(xo, xo - load3(prev, v), d, c->omega, m.bar != 0, m.sdf, m.smooth != 0, far, s,
                                   xn) == sim::kStepRejected)
        acc[1] = 1;
      if (m.bar) S[v] = s;
      store3(prev, v, xn);
    }
  }
  block_sum<2>(acc, part + 2 * blockIdx.x);
}

template <class R>
__global__ void __launch_bounds__(256) k_hess_vec(DevModel<R> m, const double* __restrict__ x,
                                                  const double* __restrict__ vin, double* __restrict__ out, int psd) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < m.n) store3(out, v, hess_vec_vertex(m, x, vin, v, psd != 0));
}

__global__ void __launch_bounds__(kCtrlThreads) k_sums(const double* pe, int nb, double* out) {
  __shared__ double sums[kSums];
  reduce_parts(pe, nb, nullptr, 0, sums);
  if (threadIdx.x == 0)
    for (int q = 0; q <= kTerms; ++q) out[q] = sums[q];
}

// The rest state from the pattern on the device (sim/rest_state.hpp).
struct RestArgs {
  DeviceRest mesh;  // the pattern and topology; its rest state is what the kernels write below
  const int32_t *nbr_ptr = nullptr, *nbr_idx = nullptr;
  double *rest_L = nullptr, *tri_area = nullptr, *hinge_K = nullptr, *hinge_w = nullptr, *Q = nullptr;
  double *mass = nullptr, *barrier_c = nullptr, *part = nullptr;
  uint8_t* floored = nullptr;
  double L_floor = 0, m_floor = 0, density = 0, bscale = 0;
};

// Springs, triangles and hinges: one element of each per thread.
__global__ void k_rest_elements(RestArgs a) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  const DeviceRest& m = a.mesh;
  if (k < m.n_springs)
    a.rest_L[k] = sim::spring_rest_length(m.p, m.spring_v[2 * k], m.spring_v[2 * k + 1], a.L_floor, a.floored + k);
  if (k < m.n_tris) a.tri_area[k] = sim::triangle_rest_area(m.p, m.tris + 3 * k);
  if (k < m.n_hinges) sim::hinge_rest(m.p, m.hinge_v + 4 * k, a.hinge_K + 4 * k, a.hinge_w + k);
}

// Per vertex: mass, barrier weight and Q's row; per block: sum of m^2.
__global__ void k_rest_vertices(RestArgs a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double m2[1] = {0};
  const DeviceRest& g = a.mesh;
  if (v < g.n) {
    const double m = sim::vertex_mass(v, g.vt_ptr, g.vt_idx, a.tri_area, a.density);
    a.mass[v] = m;
    a.barrier_c[v] = sim::barrier_weight(m, a.m_floor, a.bscale);
    sim::bending_q_row(v, g.vh_ptr, g.vh_idx, g.hinge_v, a.hinge_K, a.hinge_w, a.nbr_ptr, a.nbr_idx,
                       a.Q + a.nbr_ptr[v]);
    m2[0] = m * m;
  }
  block_sum<1>(m2, a.part + blockIdx.x);
}

// out[0] = sum of part[0..nb) in a fixed order (one block).
__global__ void __launch_bounds__(kCtrlThreads) k_sum_parts(const double* part, int nb, double* out) {
  __shared__ double sh[1][kCtrlThreads];
  double a = 0;
  for (int b = threadIdx.x; b < nb; b += blockDim.x) a += part[b];
  sh[0][threadIdx.x] = a;
  tree_sum(sh);
  if (threadIdx.x == 0) out[0] = sh[0][0];
}

// The least index of a vertex with phi <= 0 in the barrier's field (first_inside).
template <class R>
__global__ void k_first_inside(DevModel<R> m, const double* x, int* first) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.n) return;
  if (!(sim::barrier_field(m.sdf, m.smooth != 0, load3(x, v)).phi > 0)) atomicMin(first, v);
}

// The least index of a vertex that a solve's start could not take as it is: a
// coordinate that is not finite, or (with the barrier) phi not above `floor` (the host
// path then checks and projects it, as the CPU solver does).
template <class R>
__global__ void k_first_unsafe(DevModel<R> m, const double* x, double floor, int* first) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.n) return;
  const Vec3 p = load3(x, v);
  const bool finite = isfinite(p.x) && isfinite(p.y) && isfinite(p.z);
  if (!finite || (m.bar && !(sim::barrier_field(m.sdf, m.smooth != 0, p).phi > floor))) atomicMin(first, v);
}

__global__ void k_to_float(const double* in, float* out, size_t count) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < count) out[i] = float(in[i]);  // rounds to nearest, as the host conversion did
}

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

// ------------------------------------------------------------------ state

struct SimGpu::Impl {
  const sim::Simulator* sim = nullptr;
  GpuOptions opt;
  int n = 0, nb_step = 0, n_springs = 0, nnz = 0, n_sew_inc = 0;
  int lanes = 1;             // threads per vertex in the evaluation (opt.lanes, or chosen)
  cudaStream_t stream = nullptr;
  // Topology (fixed) and rest state (sync()).
  DevBuf spring_v, vs_ptr, vs_idx, vw_ptr, vw_idx, nbr_ptr, nbr_idx, self_slot;
  DevBuf tris, vt_ptr, vt_idx, hinge_v, vh_ptr, vh_idx;
  int n_tris = 0, n_hinges = 0;
  double L_floor = 0, m_floor = 0;
  // The pattern and its rest state in float64 (computed here from p); with
  // float_rest the model reads the float32 copies below.
  DevBuf p, rest_L64, shirring64, Q64, mass64, barrier_c64, L_floored, tri_area, hinge_K, hinge_w, rest_part;
  DevBuf rest_L, shirring, Q, mass, barrier_c;  // float32 copies (float_rest)
  DevBuf stick_k, stick_t, sdf_values, xcheck, first;
  uint64_t sdf_revision = ~uint64_t(0), rest_revision = ~uint64_t(0), shirring_revision = ~uint64_t(0),
           sticking_revision = ~uint64_t(0);
  DevModel<double> m64;
  DevModel<float> m32;
  double weight_norm = 1;
  bool bar = false;
  sim::SimParams params;
  // Iteration state.
  DevBuf xbuf[2], ck, f, D, Dsp, S, part_eval, part_step, ctrl, upd_norm, hist, sums;
  Ctrl* snap = nullptr;  // pinned host copies of the control state
  cudaGraphExec_t graph = nullptr;
  bool graph_dirty = true;

  ~Impl() {
    if (graph) cudaGraphExecDestroy(graph);
    if (snap) cudaFreeHost(snap);
    if (stream) cudaStreamDestroy(stream);
  }

  template <class F>
  void with_model(F&& fn) {
    if (opt.float_rest) fn(m32);
    else fn(m64);
  }

  // c == null: a plain evaluation of x (then k_sums reduces); otherwise a
  // solve's evaluation of the state in xbuf[new_cur], with its control step.
  template <class R, int L>
  void launch_eval_l(const DevModel<R>& m, Ctrl* c, int new_cur, const double* x) {
    EvalArgs a;
    a.c = c;
    a.x = x;
    a.f = f.as<double>();
    a.D = D.as<Sym3>();
    a.Dsp = Dsp.as<Sym3>();
    a.S = bar ? S.as<SdfSample>() : nullptr;
    a.part_eval = part_eval.as<double>();
    const int nb = int((int64_t(n) * L + opt.block - 1) / opt.block);
    if (c) k_eval<R, L, false><<<nb, opt.block, 0, stream>>>(m, a);
    else k_eval<R, L, true><<<nb, opt.block, 0, stream>>>(m, a);
    SF_CUDA(cudaGetLastError());
    if (c) {
      k_ctrl<<<1, kCtrlThreads, 0, stream>>>(c, a.part_eval, nb, part_step.as<double>(), nb_step, new_cur,
                                             upd_norm.as<double>(), hist.as<double>());
      SF_CUDA(cudaGetLastError());
    }
  }
  template <class R>
  void launch_eval(const DevModel<R>& m, Ctrl* c, int new_cur) {
    const double* x = xbuf[new_cur].as<double>();
    switch (lanes) {
      case 1: launch_eval_l<R, 1>(m, c, new_cur, x); break;
      case 2: launch_eval_l<R, 2>(m, c, new_cur, x); break;
      case 8: launch_eval_l<R, 8>(m, c, new_cur, x); break;
      default: launch_eval_l<R, 4>(m, c, new_cur, x); break;
    }
  }
  template <class R>
  void launch_step(const DevModel<R>& m, int p) {
    k_step<R><<<nb_step, opt.block, 0, stream>>>(m, ctrl.as<Ctrl>(), xbuf[p].as<double>(), xbuf[1 - p].as<double>(),
                                                 ck.as<double>(), f.as<double>(), D.as<Sym3>(),
                                                 bar ? S.as<SdfSample>() : nullptr, part_step.as<double>());
    SF_CUDA(cudaGetLastError());
  }
  // One iteration slot from the state in xbuf[p]; the new state lands in xbuf[1 - p].
  void launch_slot(int p) {
    with_model([&](auto& m) {
      launch_step(m, p);
      launch_eval(m, ctrl.as<Ctrl>(), 1 - p);
    });
  }
  void launch_batch() {
    if (!opt.use_graph) {
      for (int s = 0; s < opt.batch; ++s) launch_slot(s & 1);
      return;
    }
    if (graph_dirty || !graph) {
      if (graph) cudaGraphExecDestroy(graph);
      graph = nullptr;
      cudaGraph_t g;
      SF_CUDA(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal));
      for (int s = 0; s < opt.batch; ++s) launch_slot(s & 1);
      SF_CUDA(cudaStreamEndCapture(stream, &g));
      const cudaError_t e = cudaGraphInstantiate(&graph, g, 0);
      cudaGraphDestroy(g);
      check(e, "cudaGraphInstantiate");
      graph_dirty = false;
    }
    SF_CUDA(cudaGraphLaunch(graph, stream));
  }
  // Two lanes per vertex when the evaluation still fits one wave of resident
  // blocks, else one: the kernel is latency bound, so more threads in flight
  // help only while they all run at once, and measured on an H200 (see
  // docs/gpu_results.md) 4 or 8 lanes never beat 2 by more than the noise.
  int auto_lanes() {
    int dev = 0, sms = 0;
    SF_CUDA(cudaGetDevice(&dev));
    SF_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    int best = 1;
    for (int L : {2}) {
      int per_sm = 0;
      cudaError_t e = cudaSuccess;
      if (opt.float_rest) {
        e = L == 2 ? cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<float, 2, false>, opt.block, 0)
          : L == 4 ? cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<float, 4, false>, opt.block, 0)
                   : cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<float, 8, false>, opt.block, 0);
      } else {
        e = L == 2 ? cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<double, 2, false>, opt.block, 0)
          : L == 4 ? cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<double, 4, false>, opt.block, 0)
                   : cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, k_eval<double, 8, false>, opt.block, 0);
      }
      check(e, "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
      const int64_t blocks = (int64_t(n) * L + opt.block - 1) / opt.block;
      if (blocks <= int64_t(per_sm) * sms) best = L;
    }
    return best;
  }
  Ctrl read_ctrl() {
    SF_CUDA(cudaMemcpyAsync(snap, ctrl.p, sizeof(Ctrl), cudaMemcpyDeviceToHost, stream));
    SF_CUDA(cudaStreamSynchronize(stream));
    return *snap;
  }
};

namespace {

void to_float(DevBuf& out, const DevBuf& in, size_t count, cudaStream_t s) {
  out.reserve(count * sizeof(float));
  if (count) k_to_float<<<unsigned((count + 255) / 256), 256, 0, s>>>(in.as<double>(), out.as<float>(), count);
  SF_CUDA(cudaGetLastError());
}

template <class R>
void fill_model(DevModel<R>& m, SimGpu::Impl& I) {
  m.n = I.n;
  m.spring_v = I.spring_v.as<int32_t>();
  m.vs_ptr = I.vs_ptr.as<int32_t>();
  m.vs_idx = I.vs_idx.as<int32_t>();
  m.vw_ptr = I.vw_ptr.as<int32_t>();
  m.vw_idx = I.vw_idx.as<int32_t>();
  m.nbr_ptr = I.nbr_ptr.as<int32_t>();
  m.nbr_idx = I.nbr_idx.as<int32_t>();
  m.self_slot = I.self_slot.as<int32_t>();
  const bool f64 = std::is_same_v<R, double>;
  m.rest_L = (f64 ? I.rest_L64 : I.rest_L).as<R>();
  m.shirring = (f64 ? I.shirring64 : I.shirring).as<R>();
  m.Q = (f64 ? I.Q64 : I.Q).as<R>();
  m.mass = (f64 ? I.mass64 : I.mass).as<R>();
  m.barrier_c = (f64 ? I.barrier_c64 : I.barrier_c).as<R>();
  m.stick_k = I.stick_k.as<double>();
  m.stick_t = I.stick_t.as<double>();
  const sim::SimParams& p = I.params;
  m.Y = p.stretch_Y;
  m.Ys = p.sewing_Y;
  m.kb = p.bend_kb;
  m.dhat = p.barrier_distance;
  m.gv = p.gravity;
  m.grav = p.density > 0 && norm2(p.gravity) > 0;
  m.bar = I.bar;
  m.smooth = p.barrier_smooth;
}

}  // namespace

SimGpu::SimGpu(const sim::Simulator& s, const GpuOptions& opt) : opt_(opt), impl_(new Impl) {
  Impl& I = *impl_;
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess || count == 0) {
    cudaGetLastError();
    throw CudaError("no CUDA GPU or driver is present on this machine");
  }
  if (opt.device < 0 || opt.device >= count)
    throw CudaError("CUDA device " + std::to_string(opt.device) + " does not exist (" + std::to_string(count) +
                    " present)");
  if (opt.block != 32 && opt.block != 64 && opt.block != 128 && opt.block != 256)
    throw CudaError("block size must be 32, 64, 128 or 256");
  if (opt.lanes != 0 && opt.lanes != 1 && opt.lanes != 2 && opt.lanes != 4 && opt.lanes != 8)
    throw CudaError("lanes per vertex must be 0 (automatic), 1, 2, 4 or 8");
  if (opt.batch < 2 || opt.batch % 2) throw CudaError("batch must be even and >= 2");
  SF_CUDA(cudaSetDevice(opt.device));
  I.sim = &s;
  I.opt = opt;
  SF_CUDA(cudaStreamCreateWithFlags(&I.stream, cudaStreamNonBlocking));
  SF_CUDA(cudaMallocHost(&I.snap, sizeof(Ctrl)));
  const sim::SimArrays a = s.arrays();
  I.n = a.n;
  I.nb_step = (a.n + opt.block - 1) / opt.block;
  I.lanes = opt.lanes > 0 ? opt.lanes : I.auto_lanes();
  const int nb_eval = int((int64_t(a.n) * 8 + opt.block - 1) / opt.block);  // the most lanes allow
  I.n_springs = a.n_springs;
  I.nnz = a.nbr_ptr[a.n];
  I.n_sew_inc = a.vw_ptr[a.n];
  upload(I.spring_v, a.spring_v, 2 * size_t(a.n_springs), I.stream);
  upload(I.vs_ptr, a.vs_ptr, size_t(a.n) + 1, I.stream);
  upload(I.vs_idx, a.vs_idx, size_t(a.vs_ptr[a.n]), I.stream);
  upload(I.vw_ptr, a.vw_ptr, size_t(a.n) + 1, I.stream);
  upload(I.vw_idx, a.vw_idx, size_t(a.vw_ptr[a.n]), I.stream);
  upload(I.nbr_ptr, a.nbr_ptr, size_t(a.n) + 1, I.stream);
  upload(I.nbr_idx, a.nbr_idx, size_t(I.nnz), I.stream);
  upload(I.self_slot, a.self_slot, size_t(a.n), I.stream);
  I.n_tris = a.n_tris;
  I.n_hinges = a.n_hinges;
  I.L_floor = a.L_floor;
  I.m_floor = a.m_floor;
  upload(I.tris, a.tris, 3 * size_t(a.n_tris), I.stream);
  upload(I.vt_ptr, a.vt_ptr, size_t(a.n) + 1, I.stream);
  upload(I.vt_idx, a.vt_idx, size_t(a.vt_ptr[a.n]), I.stream);
  upload(I.hinge_v, a.hinge_v, 4 * size_t(a.n_hinges), I.stream);
  upload(I.vh_ptr, a.vh_ptr, size_t(a.n) + 1, I.stream);
  upload(I.vh_idx, a.vh_idx, size_t(a.vh_ptr[a.n]), I.stream);
  const size_t n3 = 3 * size_t(a.n);
  for (auto& b : I.xbuf) b.reserve(n3 * sizeof(double));
  I.ck.reserve(n3 * sizeof(double));
  I.f.reserve(n3 * sizeof(double));
  I.D.reserve(size_t(a.n) * sizeof(Sym3));
  I.part_eval.reserve(size_t(nb_eval) * (kTerms + 1) * sizeof(double));
  I.part_step.reserve(size_t(I.nb_step) * 2 * sizeof(double));
  I.ctrl.reserve(sizeof(Ctrl));
  I.sums.reserve(kSums * sizeof(double));
  I.upd_norm.reserve(64 * sizeof(double));
  I.hist.reserve(3 * 1024 * sizeof(double));
  sync();
}

SimGpu::~SimGpu() = default;

void SimGpu::sync() {
  Impl& I = *impl_;
  const sim::SimArrays a = I.sim->arrays();  // does not recompute the CPU's rest state
  if (a.n != I.n || a.n_springs != I.n_springs) throw CudaError("the simulator's topology changed under its GPU copy");
  I.params = I.sim->params();
  const size_t E = size_t(a.n_springs);
  if (a.shirring_revision != I.shirring_revision) {
    upload(I.shirring64, a.shirring, E, I.stream);
    if (opt_.float_rest) to_float(I.shirring, I.shirring64, E, I.stream);
    I.shirring_revision = a.shirring_revision;
  }
  if (a.sticking_revision != I.sticking_revision) {
    upload(I.stick_k, a.stick_k, size_t(a.n), I.stream);
    upload(I.stick_t, a.stick_t, 3 * size_t(a.n), I.stream);
    I.sticking_revision = a.sticking_revision;
  }
  if (a.sdf_revision != I.sdf_revision) {
    if (a.has_sdf) upload(I.sdf_values, a.sdf.values, size_t(a.sdf.nx) * a.sdf.ny * a.sdf.nz, I.stream);
    else I.sdf_values.release();
    I.sdf_revision = a.sdf_revision;
  }
  if (a.rest_revision != I.rest_revision) {
    upload(I.p, a.p, 2 * size_t(a.n), I.stream);
    update_rest_state();
    I.rest_revision = a.rest_revision;
  }
  I.bar = a.has_sdf && I.params.mu > 0;
  if (I.bar) I.S.reserve(size_t(a.n) * sizeof(SdfSample));
  refresh_model();
  SF_CUDA(cudaStreamSynchronize(I.stream));  // the host arrays may change after this returns
}

void SimGpu::refresh_model() {
  Impl& I = *impl_;
  const sim::SimArrays a = I.sim->arrays();
  SdfGridView g = a.sdf;
  g.values = a.has_sdf ? I.sdf_values.as<float>() : nullptr;
  // The model is baked into the graph's kernel arguments; new values behind the
  // same pointers (a new rest state) are not. Compared byte for byte (fill_model
  // writes fields only, so padding compares equal).
  unsigned char old64[sizeof(DevModel<double>)], old32[sizeof(DevModel<float>)];
  std::memcpy(old64, &I.m64, sizeof old64);
  std::memcpy(old32, &I.m32, sizeof old32);
  fill_model(I.m64, I);
  fill_model(I.m32, I);
  I.m64.stick = I.m32.stick = a.any_sticking;
  I.m64.sdf = I.m32.sdf = g;
  if (std::memcmp(old64, &I.m64, sizeof old64) != 0 || std::memcmp(old32, &I.m32, sizeof old32) != 0)
    I.graph_dirty = true;
}

void SimGpu::set_pattern_device(const double* d_p) {
  Impl& I = *impl_;
  sync();  // anything else the CPU model changed comes first
  if (d_p != I.p.as<double>())
    SF_CUDA(cudaMemcpyAsync(I.p.p, d_p, 2 * size_t(I.n) * sizeof(double), cudaMemcpyDeviceToDevice, I.stream));
  update_rest_state();  // synchronizes
  refresh_model();
}

void SimGpu::update_rest_state() {
  Impl& I = *impl_;
  const size_t n = size_t(I.n), E = size_t(I.n_springs), T = size_t(I.n_tris), H = size_t(I.n_hinges),
               nnz = size_t(I.nnz);
  I.rest_L64.reserve(E * sizeof(double));
  I.L_floored.reserve(E);
  I.tri_area.reserve(T * sizeof(double));
  I.hinge_K.reserve(4 * H * sizeof(double));
  I.hinge_w.reserve(H * sizeof(double));
  I.Q64.reserve(nnz * sizeof(double));
  I.mass64.reserve(n * sizeof(double));
  I.barrier_c64.reserve(n * sizeof(double));
  const int nbv = int((n + kRestBlock - 1) / kRestBlock);
  I.rest_part.reserve(size_t(nbv + 1) * sizeof(double));
  RestArgs r;
  r.mesh = device_rest();  // after the reserves above: its pointers are final
  r.nbr_ptr = I.nbr_ptr.as<int32_t>();
  r.nbr_idx = I.nbr_idx.as<int32_t>();
  r.rest_L = I.rest_L64.as<double>();
  r.floored = I.L_floored.as<uint8_t>();
  r.tri_area = I.tri_area.as<double>();
  r.hinge_K = I.hinge_K.as<double>();
  r.hinge_w = I.hinge_w.as<double>();
  r.Q = I.Q64.as<double>();
  r.mass = I.mass64.as<double>();
  r.barrier_c = I.barrier_c64.as<double>();
  r.part = I.rest_part.as<double>();
  r.L_floor = I.L_floor;
  r.m_floor = I.m_floor;
  r.density = I.params.density;
  r.bscale = I.params.mu * I.params.barrier_length * sim::kG0;
  const size_t ne = std::max({E, T, H, size_t(1)});
  k_rest_elements<<<unsigned((ne + kRestBlock - 1) / kRestBlock), kRestBlock, 0, I.stream>>>(r);
  k_rest_vertices<<<nbv, kRestBlock, 0, I.stream>>>(r);
  k_sum_parts<<<1, kCtrlThreads, 0, I.stream>>>(r.part, nbv, r.part + nbv);
  SF_CUDA(cudaGetLastError());
  if (opt_.float_rest) {
    to_float(I.rest_L, I.rest_L64, E, I.stream);
    to_float(I.Q, I.Q64, nnz, I.stream);
    to_float(I.mass, I.mass64, n, I.stream);
    to_float(I.barrier_c, I.barrier_c64, n, I.stream);
  }
  double m2 = 0;
  SF_CUDA(cudaMemcpyAsync(&m2, r.part + nbv, sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  // As Simulator::update_rest_state: massless cloth gets an absolute residual.
  I.weight_norm = sim::kG0 * std::sqrt(m2);
  if (!(I.weight_norm > 0)) I.weight_norm = 1.0;
}

double SimGpu::weight_norm() const { return impl_->weight_norm; }

int SimGpu::first_inside(const double* x, double* phi_out) {
  Impl& I = *impl_;
  if (!I.bar) return -1;
  upload(I.xcheck, x, 3 * size_t(I.n), I.stream);
  I.first.reserve(sizeof(int));
  const int none = I.n;
  SF_CUDA(cudaMemcpyAsync(I.first.p, &none, sizeof(int), cudaMemcpyHostToDevice, I.stream));
  I.with_model([&](auto& m) {
    k_first_inside<<<(I.n + 255) / 256, 256, 0, I.stream>>>(m, I.xcheck.as<double>(), I.first.as<int>());
  });
  SF_CUDA(cudaGetLastError());
  int v = none;
  SF_CUDA(cudaMemcpyAsync(&v, I.first.p, sizeof(int), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  if (v >= I.n) return -1;
  if (phi_out) {
    const sim::SimArrays a = I.sim->arrays();
    *phi_out = sim::barrier_field(a.sdf, I.params.barrier_smooth, make_vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2])).phi;
  }
  return v;
}

int SimGpu::first_unsafe_device(const double* d_x, double floor) {
  Impl& I = *impl_;
  I.first.reserve(sizeof(int));
  const int none = I.n;
  SF_CUDA(cudaMemcpyAsync(I.first.p, &none, sizeof(int), cudaMemcpyHostToDevice, I.stream));
  I.with_model([&](auto& m) {
    k_first_unsafe<<<(I.n + 255) / 256, 256, 0, I.stream>>>(m, d_x, floor, I.first.as<int>());
  });
  SF_CUDA(cudaGetLastError());
  int v = none;
  SF_CUDA(cudaMemcpyAsync(&v, I.first.p, sizeof(int), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  return v < I.n ? v : -1;
}

void copy_to_host(void* dst, const void* src, size_t bytes) {
  SF_CUDA(cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToHost));
}

DeviceRest SimGpu::device_rest() const {
  const Impl& I = *impl_;
  DeviceRest d;
  d.n = I.n;
  d.n_springs = I.n_springs;
  d.n_tris = I.n_tris;
  d.n_hinges = I.n_hinges;
  d.p = I.p.as<double>();
  d.rest_L = I.rest_L64.as<double>();
  d.shirring = I.shirring64.as<double>();
  d.mass = I.mass64.as<double>();
  d.L_floored = I.L_floored.as<uint8_t>();
  d.spring_v = I.spring_v.as<int32_t>();
  d.vs_ptr = I.vs_ptr.as<int32_t>();
  d.vs_idx = I.vs_idx.as<int32_t>();
  d.tris = I.tris.as<int32_t>();
  d.vt_ptr = I.vt_ptr.as<int32_t>();
  d.vt_idx = I.vt_idx.as<int32_t>();
  d.hinge_v = I.hinge_v.as<int32_t>();
  d.vh_ptr = I.vh_ptr.as<int32_t>();
  d.vh_idx = I.vh_idx.as<int32_t>();
  return d;
}

double SimGpu::force(const double* x, double* fout, sim::EnergyTerms* terms) {
  Impl& I = *impl_;
  const size_t n3 = 3 * size_t(I.n);
  SF_CUDA(cudaMemcpyAsync(I.xbuf[0].p, x, n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  I.with_model([&](auto& m) { I.launch_eval(m, nullptr, 0); });
  const int nb_eval = int((int64_t(I.n) * I.lanes + opt_.block - 1) / opt_.block);
  k_sums<<<1, kCtrlThreads, 0, I.stream>>>(I.part_eval.as<double>(), nb_eval, I.sums.as<double>());
  SF_CUDA(cudaGetLastError());
  double s[kTerms + 1];
  SF_CUDA(cudaMemcpyAsync(s, I.sums.p, sizeof s, cudaMemcpyDeviceToHost, I.stream));
  if (fout) SF_CUDA(cudaMemcpyAsync(fout, I.f.p, n3 * sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  sim::EnergyTerms t;
  t.stretch = s[kStretch];
  t.sewing = s[kSewing];
  t.bending = s[kBending];
  t.gravity = s[kGravity];
  t.sticking = s[kSticking];
  t.barrier = s[kBarrier];
  if (terms) *terms = t;
  return t.total();
}

double SimGpu::energy(const double* x, sim::EnergyTerms* terms) { return force(x, nullptr, terms); }
void SimGpu::hess_vec(const double* x, const double* v, double* out, bool psd) {
  Impl& I = *impl_;
  const size_t n3 = 3 * size_t(I.n);
  // Outside a solve the two state buffers and the force buffer are scratch.
  SF_CUDA(cudaMemcpyAsync(I.xbuf[0].p, x, n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  SF_CUDA(cudaMemcpyAsync(I.xbuf[1].p, v, n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  const int nb = (I.n + opt_.block - 1) / opt_.block;
  I.with_model([&](auto& m) {
    using M = std::decay_t<decltype(m)>;
    using R = std::remove_const_t<std::remove_pointer_t<decltype(M::rest_L)>>;
    k_hess_vec<R><<<nb, opt_.block, 0, I.stream>>>(m, I.xbuf[0].as<double>(), I.xbuf[1].as<double>(),
                                                  I.f.as<double>(), psd ? 1 : 0);
  });
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaMemcpyAsync(out, I.f.p, n3 * sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
}


sim::SolveReport SimGpu::solve(double* x, const sim::SolveSettings& st, const sim::ProgressFn& progress,
                               const std::atomic<bool>* cancel) {
  Impl& I = *impl_;
  const auto t0 = Clock::now();
  const int n3 = 3 * I.n;
  for (int i = 0; i < n3; ++i)
    if (!std::isfinite(x[i]))
      throw sim::SimError("simulator: start position of vertex " + std::to_string(i / 3) + " is not finite");
  if (st.method != 0)
    throw sim::SimError("the CUDA backend runs the Chebyshev solver (method 0); Newton runs on the CPU");
  sim::SolveReport rep;
  std::vector<double> xh(x, x + n3);
  if (I.bar) rep.projections += I.sim->project_outside(xh.data(), sim::kProjectFloor, I.sim->projection_gap());
  for (int b = 0; b < 2; ++b)
    SF_CUDA(cudaMemcpyAsync(I.xbuf[b].p, xh.data(), n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  SF_CUDA(cudaMemcpyAsync(I.ck.p, xh.data(), n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  int cur = 0;
  rep = run_chebyshev(st, progress, cancel, t0, rep, cur);
  SF_CUDA(cudaMemcpyAsync(x, I.xbuf[cur].p, n3 * sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  rep.seconds = seconds_since(t0);
  return rep;
}

sim::SolveReport SimGpu::solve_device(double* d_x, const sim::SolveSettings& st, const sim::ProgressFn& progress,
                                      const std::atomic<bool>* cancel) {
  Impl& I = *impl_;
  const auto t0 = Clock::now();
  const size_t bytes = 3 * size_t(I.n) * sizeof(double);
  if (st.method != 0)
    throw sim::SimError("the CUDA backend runs the Chebyshev solver (method 0); Newton runs on the CPU");
  // A start the host path would change or reject (a coordinate not finite, a vertex
  // to project out of the body) goes through it, so both paths keep the CPU's rules;
  // the search's states are outside the body already, and stay on the device.
  if (first_unsafe_device(d_x, sim::kProjectFloor) >= 0) {
    std::vector<double> xh(3 * size_t(I.n));
    copy_to_host(xh.data(), d_x, bytes);
    sim::SolveReport rep = solve(xh.data(), st, progress, cancel);
    // On this stream and waited for: a plain cudaMemcpy from pageable memory may return
    // before its DMA lands, and the next reader of d_x may run on another stream.
    SF_CUDA(cudaMemcpyAsync(d_x, xh.data(), bytes, cudaMemcpyHostToDevice, I.stream));
    SF_CUDA(cudaStreamSynchronize(I.stream));
    rep.seconds = seconds_since(t0);
    return rep;
  }
  for (int b = 0; b < 2; ++b)
    SF_CUDA(cudaMemcpyAsync(I.xbuf[b].p, d_x, bytes, cudaMemcpyDeviceToDevice, I.stream));
  SF_CUDA(cudaMemcpyAsync(I.ck.p, d_x, bytes, cudaMemcpyDeviceToDevice, I.stream));
  int cur = 0;
  sim::SolveReport rep = run_chebyshev(st, progress, cancel, t0, sim::SolveReport(), cur);
  SF_CUDA(cudaMemcpyAsync(d_x, I.xbuf[cur].p, bytes, cudaMemcpyDeviceToDevice, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  rep.seconds = seconds_since(t0);
  return rep;
}

sim::SolveReport SimGpu::run_chebyshev(const sim::SolveSettings& st, const sim::ProgressFn& progress,
                                       const std::atomic<bool>* cancel, std::chrono::steady_clock::time_point t0,
                                       sim::SolveReport rep, int& cur) {
  Impl& I = *impl_;
  Ctrl c;
  c.tol = st.tolerance;
  c.weight_norm = I.weight_norm;
  c.max_it = st.max_iterations;
  c.warmup = std::max(st.warmup, 2);
  c.check = std::max(st.check_every, 1);
  c.history_every = st.history_every;
  // The residual history keeps its first 2^17 entries (1.3M iterations at the default interval).
  c.hist_cap = st.history_every > 0 ? std::min(st.max_iterations / st.history_every + 2, 1 << 17) : 0;
  c.auto_rho = !(st.rho > 0);
  c.rho_max = st.rho_max;
  c.rho = c.auto_rho ? 0.0 : std::min(st.rho, 0.99999);
  c.alpha = c.alpha0 = std::min(std::max(st.alpha, 1e-3), 1.0);
  // The CPU's economies with the CPU's settings (solve_chebyshev).
  c.precond_refresh = std::max(st.precond_refresh, 1);
  c.far = I.bar ? sim::far_step_threshold(st.far_bound, I.params.barrier_distance) : 0.0;
  c.mode = kInit;
  // Buffers baked into the graph: growing them means capturing it again.
  if (c.precond_refresh > 1 && I.Dsp.reserve(size_t(I.n) * sizeof(Sym3))) I.graph_dirty = true;
  if (I.upd_norm.reserve(size_t(c.warmup) * sizeof(double))) I.graph_dirty = true;
  if (I.hist.reserve(3 * size_t(std::max(c.hist_cap, 1)) * sizeof(double))) I.graph_dirty = true;
  *I.snap = c;
  SF_CUDA(cudaMemcpyAsync(I.ctrl.p, I.snap, sizeof(Ctrl), cudaMemcpyHostToDevice, I.stream));
  // The start state: evaluate, then the top of iteration 0.
  I.with_model([&](auto& m) {
    I.launch_step(m, 1);  // kInit: samples the field at xbuf[0]
    I.launch_eval(m, I.ctrl.as<Ctrl>(), 0);
  });
  c = I.read_ctrl();
  const double t_start = seconds_since(t0);  // host time before the device clock started

  bool cancelled = false, timed_out = false;
  int last_progress = 0;
  auto host_checks = [&](const Ctrl& cc) {
    // The CPU solver's host-side rules, once per batch.
    if (st.max_seconds > 0 && seconds_since(t0) > st.max_seconds) timed_out = true;
    else if (cancel && cancel->load()) cancelled = true;
    else if (progress && st.progress_every > 0 &&
             (cc.it == 0 || cc.it / st.progress_every > last_progress / st.progress_every)) {
      last_progress = cc.it;
      if (!progress(cc.it, cc.res)) cancelled = true;
    }
  };
  if (!c.done && c.mode == kStep) host_checks(c);
  while (!c.done && !cancelled && !timed_out) {
    I.launch_batch();
    c = I.read_ctrl();
    if (!c.done) host_checks(c);
  }
  // A stop between batches may fall right after an energy rise: finish the
  // restore (the CPU solver restores within the same iteration).
  for (int guard = 0; !c.done && c.mode != kStep && guard < 2; ++guard) {
    I.launch_slot(c.cur);
    c = I.read_ctrl();
  }

  std::vector<double> hist(3 * size_t(c.hist_count));
  if (c.hist_count)
    SF_CUDA(cudaMemcpyAsync(hist.data(), I.hist.p, hist.size() * sizeof(double), cudaMemcpyDeviceToHost, I.stream));
  SF_CUDA(cudaStreamSynchronize(I.stream));
  for (int h = 0; h < c.hist_count; ++h) rep.record(hist[3 * h], t_start + hist[3 * h + 1], hist[3 * h + 2]);
  rep.iterations = c.it;
  rep.residual = c.res;
  rep.energy = c.E;
  rep.restarts = c.restarts;
  rep.rejected_steps = c.rejected;
  rep.final_rho = c.rho;
  rep.final_alpha = c.alpha;
  cur = c.cur;
  if (c.status == kConverged) {
    rep.converged = true;
    rep.message = sim::msg_converged(c.res, st.tolerance, c.it, "iterations");
  } else if (c.status == kNonFinite) {
    rep.message = sim::msg_non_finite(c.it);
  } else if (c.status == kBudget) {
    rep.message = sim::msg_iteration_budget(c.res, st.tolerance, c.it, "iterations");
  } else if (timed_out) {
    rep.message = sim::msg_time_budget(c.res, st.tolerance, seconds_since(t0));
  } else {
    rep.cancelled = true;
    rep.message = sim::msg_cancelled(c.res, c.it, "iteration");
  }
  return rep;
}

KernelTimes SimGpu::time_kernels(const double* x, int reps) {
  Impl& I = *impl_;
  reps = std::max(reps, 2) & ~1;
  const int n3 = 3 * I.n;
  for (int b = 0; b < 2; ++b)
    SF_CUDA(cudaMemcpyAsync(I.xbuf[b].p, x, n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  SF_CUDA(cudaMemcpyAsync(I.ck.p, x, n3 * sizeof(double), cudaMemcpyHostToDevice, I.stream));
  Ctrl c;
  c.tol = 0;  // never converges
  c.weight_norm = I.weight_norm;
  c.max_it = 1 << 30;
  c.check = 1 << 30;  // no energy checks: every slot is a step
  c.warmup = 2;
  c.mode = kInit;
  I.upd_norm.reserve(2 * sizeof(double));
  *I.snap = c;
  SF_CUDA(cudaMemcpyAsync(I.ctrl.p, I.snap, sizeof(Ctrl), cudaMemcpyHostToDevice, I.stream));
  I.with_model([&](auto& m) {
    I.launch_step(m, 1);  // kInit: samples the field at xbuf[0]
    I.launch_eval(m, I.ctrl.as<Ctrl>(), 0);
  });
  SF_CUDA(cudaStreamSynchronize(I.stream));
  I.graph_dirty = true;

  cudaEvent_t e0, e1;
  SF_CUDA(cudaEventCreate(&e0));
  SF_CUDA(cudaEventCreate(&e1));
  auto time_graph = [&](auto&& body) {
    cudaGraph_t g;
    cudaGraphExec_t ge;
    SF_CUDA(cudaStreamBeginCapture(I.stream, cudaStreamCaptureModeThreadLocal));
    for (int r = 0; r < reps; ++r) body(r);
    SF_CUDA(cudaStreamEndCapture(I.stream, &g));
    SF_CUDA(cudaGraphInstantiate(&ge, g, 0));
    SF_CUDA(cudaGraphLaunch(ge, I.stream));  // warm-up
    std::vector<float> ms;
    for (int k = 0; k < 7; ++k) {
      SF_CUDA(cudaEventRecord(e0, I.stream));
      SF_CUDA(cudaGraphLaunch(ge, I.stream));
      SF_CUDA(cudaEventRecord(e1, I.stream));
      SF_CUDA(cudaEventSynchronize(e1));
      float t = 0;
      SF_CUDA(cudaEventElapsedTime(&t, e0, e1));
      ms.push_back(t);
    }
    cudaGraphExecDestroy(ge);
    cudaGraphDestroy(g);
    std::sort(ms.begin(), ms.end());
    return 1e3 * ms[ms.size() / 2] / reps;
  };
  KernelTimes kt;
  // The evaluation reads the samples the start evaluation stored (as after a step).
  I.with_model([&](auto& m) {
    kt.eval_us = time_graph([&](int) { I.launch_eval(m, I.ctrl.as<Ctrl>(), 0); });
  });
  // Every slot is a step (no checks); parity alternates within the graph.
  kt.slot_us = time_graph([&](int r) { I.launch_slot(r & 1); });
  I.with_model([&](auto& m) { kt.step_us = time_graph([&](int r) { I.launch_step(m, r & 1); }); });
  cudaEventDestroy(e0);
  cudaEventDestroy(e1);
  SF_CUDA(cudaStreamSynchronize(I.stream));

  // Unique bytes each kernel must move (every array once; the SDF grid, read
  // through the cache at a few cells per vertex, not counted).
  const double n = I.n, E = I.n_springs, nnz = I.nnz, K = I.n_sew_inc, r = I.opt.float_rest ? 4 : 8;
  const double idx = 4;
  const double topo = idx * (3 * (n + 1) + 2 * E + 2 * E + K + nnz + n);  // CSR pointers, vs, spring_v, vw, nbr, self
  const double rest = r * (2 * E + nnz + 2 * n);
  const double samples = I.bar ? 32 * n : 0;
  kt.eval_bytes = topo + rest + 24 * n /*x*/ + samples + 24 * n /*f*/ + 48 * n /*D*/;
  kt.step_bytes = 24 * n /*f*/ + 48 * n /*D*/ + 24 * n /*x_k*/ + 2 * 24 * n /*x_{k-1} read, x_{k+1} write*/ +
                  2 * samples;
  return kt;
}

const sim::Simulator& SimGpu::simulator() const { return *impl_->sim; }
const void* SimGpu::device_model() const {
  return opt_.float_rest ? static_cast<const void*>(&impl_->m32) : static_cast<const void*>(&impl_->m64);
}
void* SimGpu::stream_handle() const { return impl_->stream; }
int SimGpu::lanes() const { return impl_->lanes; }

std::string SimGpu::device_name() const {
  cudaDeviceProp p;
  if (cudaGetDeviceProperties(&p, opt_.device) != cudaSuccess) return std::string();
  return p.name;
}

size_t SimGpu::device_bytes() const {
  const Impl& I = *impl_;
  size_t s = 0;
  for (const DevBuf* b : {&I.spring_v, &I.vs_ptr, &I.vs_idx, &I.vw_ptr, &I.vw_idx, &I.nbr_ptr, &I.nbr_idx,
                          &I.self_slot, &I.rest_L, &I.shirring, &I.Q, &I.mass, &I.barrier_c, &I.stick_k, &I.stick_t,
                          &I.tris, &I.vt_ptr, &I.vt_idx, &I.hinge_v, &I.vh_ptr, &I.vh_idx, &I.p, &I.rest_L64,
                          &I.shirring64, &I.Q64, &I.mass64, &I.barrier_c64, &I.L_floored, &I.tri_area, &I.hinge_K,
                          &I.hinge_w, &I.rest_part,
                          &I.sdf_values, &I.xbuf[0], &I.xbuf[1], &I.ck, &I.f, &I.D, &I.Dsp, &I.S, &I.part_eval,
                          &I.part_step, &I.ctrl, &I.upd_norm, &I.hist, &I.sums})
    s += b->bytes;
  return s;
}

}  // namespace seamfit::cuda
