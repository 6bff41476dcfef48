#include "opt/costs_gpu.hpp"

#include <cuda_runtime.h>

#include <stdexcept>
#include <vector>

#include "device/dev_buffer.cuh"
#include "opt/costs/distance.hpp"
#include "opt/costs/gather.hpp"
#include "opt/costs/positional.hpp"
#include "opt/costs/smoothness.hpp"
#include "opt/costs/stretching.hpp"

namespace seamfit::cuda {

namespace {

constexpr int kBlock = 128;
int blocks(int n) { return (n + kBlock - 1) / kBlock; }

struct Args {
  int n = 0, ne = 0, nh = 0;
  const Vec3* x = nullptr;
  const Vec2* p = nullptr;
  const int *edges = nullptr, *hinges = nullptr;
  const double *rbar = nullptr, *hinge_w = nullptr, *cbar = nullptr, *sbar = nullptr;
  const int *e_off = nullptr, *e_slots = nullptr, *h_off = nullptr, *h_slots = nullptr;
  const double *phibar = nullptr, *u = nullptr;
  const Vec3* xtilde = nullptr;
  SdfGridView sdf;
  double dis = 0, smo = 0, str = 0, pos = 0;
  double *val_d = nullptr, *val_p = nullptr, *val_s = nullptr, *val_h = nullptr;
  Vec3 *slot_ex = nullptr, *slot_hx = nullptr, *gx = nullptr;
  Vec2 *slot_ep = nullptr, *gp = nullptr;
  double* part = nullptr;  // per block and term
};

// The per-vertex terms, written as the vertex's gradient start (the CPU's order:
// distance, then positional).
__global__ void k_vertex_terms(Args a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= a.n) return;
  Vec3 g = make_vec3(0, 0, 0), gi;
  if (a.dis != 0) {
    a.val_d[i] = distance_cost(a.sdf, a.x[i], a.phibar[i], a.dis, &gi);
    g += gi;
  }
  if (a.pos != 0) {
    a.val_p[i] = positional_cost(a.x[i], a.xtilde[i], a.pos * a.u[i], &gi);
    g += gi;
  }
  a.gx[i] = g;
  a.gp[i] = make_vec2(0, 0);
}

__global__ void k_edges(Args a) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= a.ne) return;
  const int i = a.edges[2 * e], j = a.edges[2 * e + 1];
  a.val_s[e] = stretching_cost(a.x[i], a.x[j], a.p[i], a.p[j], a.rbar[e], a.str, &a.slot_ex[2 * e],
                                    &a.slot_ex[2 * e + 1], &a.slot_ep[2 * e], &a.slot_ep[2 * e + 1]);
}

__global__ void k_hinges(Args a) {
  const int h = blockIdx.x * blockDim.x + threadIdx.x;
  if (h >= a.nh) return;
  const int* hg = a.hinges + 4 * h;
  const Vec3 xs[4] = {a.x[hg[0]], a.x[hg[1]], a.x[hg[2]], a.x[hg[3]]};
  a.val_h[h] = smoothness_cost(xs, a.hinge_w + 4 * h, a.cbar[h], a.sbar[h], a.smo, a.slot_hx + 4 * h);
}

__global__ void k_gather(Args a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= a.n) return;
  Vec3 g = a.gx[v];
  Vec2 q = a.gp[v];
  if (a.str != 0) {
    gather_add(v, a.e_off, a.e_slots, a.slot_ex, g);
    gather_add(v, a.e_off, a.e_slots, a.slot_ep, q);
  }
  if (a.smo != 0) gather_add(v, a.h_off, a.h_slots, a.slot_hx, g);
  a.gx[v] = g;
  a.gp[v] = q;
}

// Block partial sums of one term's element values (summed on the host in block order).
__global__ void k_partial(const double* val, int count, double* part) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  double v[1] = {i < count ? val[i] : 0.0};
  block_sum<1>(v, part + blockIdx.x);
}

}  // namespace

struct CostSetGpu::Impl {
  opt::CostSet* cs = nullptr;
  opt::CostSetView view;
  DevBuf edges, rbar, hinges, hinge_w, cbar, sbar, e_off, e_slots, h_off, h_slots;
  DevBuf phibar, u, xtilde, sdf_values;
  DevBuf x, p, val_d, val_p, val_s, val_h, slot_ex, slot_ep, slot_hx, gx, gp, part;
  std::vector<double> part_host;
};

CostSetGpu::CostSetGpu(opt::CostSet& cs) : impl_(new Impl) {
  Impl& I = *impl_;
  I.cs = &cs;
  const opt::CostSetView v = cs.view();
  I.view = v;
  cudaStream_t s = 0;
  upload(I.edges, v.edges, 2 * size_t(v.n_edges), s);
  upload(I.rbar, v.rbar, size_t(v.n_edges), s);
  upload(I.hinges, v.hinges, 4 * size_t(v.n_hinges), s);
  upload(I.hinge_w, v.hinge_w, 4 * size_t(v.n_hinges), s);
  upload(I.cbar, v.cbar, size_t(v.n_hinges), s);
  upload(I.sbar, v.sbar, size_t(v.n_hinges), s);
  upload(I.e_off, v.edge_offsets, size_t(v.n) + 1, s);
  upload(I.e_slots, v.edge_slots, 2 * size_t(v.n_edges), s);
  upload(I.h_off, v.hinge_offsets, size_t(v.n) + 1, s);
  upload(I.h_slots, v.hinge_slots, 4 * size_t(v.n_hinges), s);
  if (v.has_sdf) {
    upload(I.phibar, v.phibar, size_t(v.n), s);
    upload(I.sdf_values, v.sdf.values, size_t(v.sdf.nx) * v.sdf.ny * v.sdf.nz, s);
  }
  if (v.has_pos) {
    upload(I.u, v.u, size_t(v.n), s);
    upload(I.xtilde, v.xtilde, size_t(v.n), s);
  }
  const size_t n = size_t(v.n), ne = size_t(v.n_edges), nh = size_t(v.n_hinges);
  I.x.reserve(n * sizeof(Vec3));
  I.p.reserve(n * sizeof(Vec2));
  I.val_d.reserve(n * sizeof(double));
  I.val_p.reserve(n * sizeof(double));
  I.val_s.reserve(ne * sizeof(double));
  I.val_h.reserve(nh * sizeof(double));
  I.slot_ex.reserve(2 * ne * sizeof(Vec3));
  I.slot_ep.reserve(2 * ne * sizeof(Vec2));
  I.slot_hx.reserve(4 * nh * sizeof(Vec3));
  I.gx.reserve(n * sizeof(Vec3));
  I.gp.reserve(n * sizeof(Vec2));
  // The block partials of all four terms at once: no allocation on a later call.
  I.part.reserve(size_t(2 * blocks(v.n) + blocks(v.n_edges) + blocks(v.n_hinges)) * sizeof(double));
  SF_CUDA(cudaStreamSynchronize(s));
}

CostSetGpu::~CostSetGpu() = default;

double CostSetGpu::evaluate(const double* x, const double* p, double* grad_x, double* grad_p,
                            std::array<double, opt::kNumCostTerms>* terms) {
  Impl& I = *impl_;
  const size_t n = size_t(I.view.n);
  cudaStream_t s = 0;
  upload(I.x, x, 3 * n, s);
  upload(I.p, p, 2 * n, s);
  const double value = evaluate_device(I.x.as<double>(), I.p.as<double>(), I.gx.as<double>(), I.gp.as<double>(), terms);
  SF_CUDA(cudaMemcpyAsync(grad_x, I.gx.p, 3 * n * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaMemcpyAsync(grad_p, I.gp.p, 2 * n * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  return value;
}

double CostSetGpu::evaluate_device(const double* d_x, const double* d_p, double* d_grad_x, double* d_grad_p,
                                   std::array<double, opt::kNumCostTerms>* terms) {
  Impl& I = *impl_;
  const opt::CostSetView& v = I.view;
  const opt::CostStrengths k = I.cs->strengths();
  if (k.dis != 0 && !v.has_sdf) throw std::logic_error("distance cost has a strength but no target SDF");
  if (k.pos != 0 && !v.has_pos) throw std::logic_error("positional cost has a strength but no transferred garment");
  // The kernels read x and p after the first one has started writing the gradients.
  if (d_grad_x == d_x || d_grad_p == d_p)
    throw std::invalid_argument("evaluate_device: gradients must not overwrite x or p");
  cudaStream_t s = 0;
  Args a;
  a.n = v.n;
  a.ne = v.n_edges;
  a.nh = v.n_hinges;
  a.x = reinterpret_cast<const Vec3*>(d_x);
  a.p = reinterpret_cast<const Vec2*>(d_p);
  a.edges = I.edges.as<int>();
  a.hinges = I.hinges.as<int>();
  a.rbar = I.rbar.as<double>();
  a.hinge_w = I.hinge_w.as<double>();
  a.cbar = I.cbar.as<double>();
  a.sbar = I.sbar.as<double>();
  a.e_off = I.e_off.as<int>();
  a.e_slots = I.e_slots.as<int>();
  a.h_off = I.h_off.as<int>();
  a.h_slots = I.h_slots.as<int>();
  a.phibar = I.phibar.as<double>();
  a.u = I.u.as<double>();
  a.xtilde = I.xtilde.as<Vec3>();
  a.sdf = v.sdf;
  a.sdf.values = I.sdf_values.as<float>();
  a.dis = k.dis;
  a.smo = k.smo;
  a.str = k.str;
  a.pos = k.pos;
  a.val_d = I.val_d.as<double>();
  a.val_p = I.val_p.as<double>();
  a.val_s = I.val_s.as<double>();
  a.val_h = I.val_h.as<double>();
  a.slot_ex = I.slot_ex.as<Vec3>();
  a.slot_ep = I.slot_ep.as<Vec2>();
  a.slot_hx = I.slot_hx.as<Vec3>();
  a.gx = reinterpret_cast<Vec3*>(d_grad_x);
  a.gp = reinterpret_cast<Vec2*>(d_grad_p);
  k_vertex_terms<<<blocks(v.n), kBlock, 0, s>>>(a);
  if (k.str != 0 && v.n_edges) k_edges<<<blocks(v.n_edges), kBlock, 0, s>>>(a);
  if (k.smo != 0 && v.n_hinges) k_hinges<<<blocks(v.n_hinges), kBlock, 0, s>>>(a);
  k_gather<<<blocks(v.n), kBlock, 0, s>>>(a);
  // Per-term sums: block partials in a fixed order.
  const double* vals[opt::kNumCostTerms] = {};
  int counts[opt::kNumCostTerms] = {};
  if (k.dis != 0) { vals[opt::kDistance] = a.val_d; counts[opt::kDistance] = v.n; }
  if (k.smo != 0) { vals[opt::kSmoothness] = a.val_h; counts[opt::kSmoothness] = v.n_hinges; }
  if (k.str != 0) { vals[opt::kStretching] = a.val_s; counts[opt::kStretching] = v.n_edges; }
  if (k.pos != 0) { vals[opt::kPositional] = a.val_p; counts[opt::kPositional] = v.n; }
  int offset[opt::kNumCostTerms + 1] = {};
  for (int t = 0; t < opt::kNumCostTerms; ++t) offset[t + 1] = offset[t] + (vals[t] ? blocks(counts[t]) : 0);
  for (int t = 0; t < opt::kNumCostTerms; ++t)
    if (vals[t] && counts[t]) k_partial<<<blocks(counts[t]), kBlock, 0, s>>>(vals[t], counts[t], I.part.as<double>() + offset[t]);
  SF_CUDA(cudaGetLastError());
  I.part_host.resize(size_t(offset[opt::kNumCostTerms]));
  if (!I.part_host.empty())
    SF_CUDA(cudaMemcpyAsync(I.part_host.data(), I.part.p, I.part_host.size() * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  std::array<double, opt::kNumCostTerms> t{};
  for (int q = 0; q < opt::kNumCostTerms; ++q) {
    for (int b = offset[q]; b < offset[q + 1]; ++b) t[q] += I.part_host[size_t(b)];
    if (vals[q]) I.cs->count_evaluation(opt::CostTerm(q));
  }
  if (terms) *terms = t;
  return t[opt::kDistance] + t[opt::kSmoothness] + t[opt::kStretching] + t[opt::kPositional];
}

}  // namespace seamfit::cuda
