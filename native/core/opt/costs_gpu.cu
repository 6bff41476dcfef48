#include "opt/costs_gpu.hpp"

#include <cuda_runtime.h>

#include <stdexcept>
#include <utility>
#include <vector>

#include "device/dev_buffer.cuh"
#include "opt/costs/gather.hpp"

namespace seamfit::cuda {

namespace {

constexpr int kBlock = 128;
int blocks(int n) { return (n + kBlock - 1) / kBlock; }

// What the kernels read of each term, indexed by its registry number.
struct TermArgs {
  double k = 0;                     // its strength: 0, skipped
  const double* c = nullptr;        // its constants, the term's width per element
  double* val = nullptr;            // per element value
  const int *ids = nullptr, *offsets = nullptr, *slots = nullptr;  // its elements (not vertices)
  Vec3* slot_x = nullptr;           // per element gradient slots (not vertices)
  Vec2* slot_p = nullptr;           // the same for p (terms with kPattern)
};

struct Args {
  opt::CostInputs in;
  int n = 0;
  TermArgs term[opt::kNumCostTerms];
  Vec3* gx = nullptr;
  Vec2* gp = nullptr;
};

// A term over edges or hinges: each element's value and gradient slots.
template <class T>
__global__ void k_elements(opt::CostInputs in, TermArgs u, int count) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= count) return;
  constexpr int arity = opt::kElementArity[T::kOn];
  u.val[e] = T::element(in, u.ids + arity * e, u.c + size_t(T::kWidth) * e, u.k, u.slot_x + arity * e,
                        T::kPattern ? u.slot_p + arity * e : nullptr);
}

// Term number R in gradient order at vertex v: a term over the vertices evaluated there and
// added to g and q, another's gradient slots gathered (the CPU's order of additions).
template <int R>
__device__ void add_term(const Args& a, int v, Vec3& g, Vec2& q) {
  constexpr opt::CostTerm t = opt::kCostGradientOrder[R];
  using T = typename opt::CostTermType<t>::type;
  const TermArgs& u = a.term[t];
  if (u.k == 0) return;
  if constexpr (T::kOn == opt::kVertices) {
    Vec3 gi;
    Vec2 qi = make_vec2(0, 0);
    u.val[v] = T::element(a.in, &v, u.c + size_t(T::kWidth) * v, u.k, &gi, &qi);
    g += gi;
    if (T::kPattern) q += qi;
  } else {
    gather_add(v, u.offsets, u.slots, u.slot_x, g);
    if (T::kPattern) gather_add(v, u.offsets, u.slots, u.slot_p, q);
  }
}

template <int... R>
__device__ void add_terms(const Args& a, int v, Vec3& g, Vec2& q, std::integer_sequence<int, R...>) {
  (add_term<R>(a, v, g, q), ...);
}

// Each vertex's gradients, term by term in gradient order.
__global__ void k_gradient(Args a) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= a.n) return;
  Vec3 g = make_vec3(0, 0, 0);
  Vec2 q = make_vec2(0, 0);
  add_terms(a, v, g, q, std::make_integer_sequence<int, opt::kNumCostTerms>{});
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
  DevBuf ids[opt::kNumElementKinds], offsets[opt::kNumElementKinds], slots[opt::kNumElementKinds];
  DevBuf constants[opt::kNumCostTerms], val[opt::kNumCostTerms], slot_x[opt::kNumCostTerms],
      slot_p[opt::kNumCostTerms];
  DevBuf sdf_values, x, p, gx, gp, part;
  std::vector<double> part_host;
};

CostSetGpu::CostSetGpu(opt::CostSet& cs) : impl_(new Impl) {
  Impl& I = *impl_;
  I.cs = &cs;
  const opt::CostSetView v = cs.view();
  I.view = v;
  cudaStream_t s = 0;
  for (int kind = opt::kEdges; kind < opt::kNumElementKinds; ++kind) {  // the vertices have no ids
    const auto& el = v.elements[kind];
    const size_t slots = size_t(el.arity) * el.count;
    upload(I.ids[kind], el.ids, slots, s);
    upload(I.offsets[kind], el.offsets, size_t(v.n) + 1, s);
    upload(I.slots[kind], el.slots, slots, s);
  }
  if (v.has_sdf) upload(I.sdf_values, v.sdf.values, size_t(v.sdf.nx) * v.sdf.ny * v.sdf.nz, s);
  size_t partials = 0;
  for (int q = 0; q < opt::kNumCostTerms; ++q)
    opt::visit_cost_term(opt::CostTerm(q), [&](auto term) {
      using T = decltype(term);
      const size_t count = size_t(v.elements[T::kOn].count), slots = size_t(v.elements[T::kOn].arity) * count;
      if (v.ready[q]) upload(I.constants[q], v.constants[q], size_t(T::kWidth) * count, s);
      I.val[q].reserve(count * sizeof(double));
      if (T::kOn != opt::kVertices) I.slot_x[q].reserve(slots * sizeof(Vec3));
      if (T::kOn != opt::kVertices && T::kPattern) I.slot_p[q].reserve(slots * sizeof(Vec2));
      partials += size_t(blocks(int(count)));
    });
  I.x.reserve(size_t(v.n) * sizeof(Vec3));
  I.p.reserve(size_t(v.n) * sizeof(Vec2));
  I.gx.reserve(size_t(v.n) * sizeof(Vec3));
  I.gp.reserve(size_t(v.n) * sizeof(Vec2));
  // The block partials of every term at once: no allocation on a later call.
  I.part.reserve(partials * sizeof(double));
  SF_CUDA(cudaStreamSynchronize(s));
}

CostSetGpu::~CostSetGpu() = default;

double CostSetGpu::evaluate(const double* x, const double* p, double* grad_x, double* grad_p,
                            opt::CostValues* terms) {
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
                                   opt::CostValues* terms) {
  Impl& I = *impl_;
  const opt::CostSetView& v = I.view;
  const opt::CostStrengths k = I.cs->strengths();
  // The inputs this copy holds, which may predate the CPU set's.
  opt::check_cost_inputs(k, v.ready, v.has_sdf);
  // The kernels read x and p after the first one has started writing the gradients.
  if (d_grad_x == d_x || d_grad_p == d_p)
    throw std::invalid_argument("evaluate_device: gradients must not overwrite x or p");
  cudaStream_t s = 0;
  opt::CostInputs in;
  in.x = reinterpret_cast<const Vec3*>(d_x);
  in.p = reinterpret_cast<const Vec2*>(d_p);
  in.sdf = v.sdf;
  in.sdf.values = I.sdf_values.as<float>();
  Args a;
  a.in = in;
  a.n = v.n;
  a.gx = reinterpret_cast<Vec3*>(d_grad_x);
  a.gp = reinterpret_cast<Vec2*>(d_grad_p);
  // Each evaluated term's arguments, and the element pass of those over edges or hinges.
  int counts[opt::kNumCostTerms] = {};
  for (int q = 0; q < opt::kNumCostTerms; ++q) {
    if (k[q] == 0) continue;
    opt::visit_cost_term(opt::CostTerm(q), [&](auto term) {
      using T = decltype(term);
      TermArgs& u = a.term[q];
      u.k = k[q];
      u.c = I.constants[q].template as<double>();
      u.val = I.val[q].template as<double>();
      u.ids = I.ids[T::kOn].template as<int>();
      u.offsets = I.offsets[T::kOn].template as<int>();
      u.slots = I.slots[T::kOn].template as<int>();
      u.slot_x = I.slot_x[q].template as<Vec3>();
      u.slot_p = I.slot_p[q].template as<Vec2>();
      counts[q] = v.elements[T::kOn].count;
      if constexpr (T::kOn != opt::kVertices)
        if (counts[q]) k_elements<T><<<blocks(counts[q]), kBlock, 0, s>>>(in, u, counts[q]);
    });
  }
  // Then every vertex's gradient, the vertices' own terms evaluated there.
  if (v.n) k_gradient<<<blocks(v.n), kBlock, 0, s>>>(a);
  // Per-term sums: block partials in a fixed order.
  int offset[opt::kNumCostTerms + 1] = {};
  for (int t = 0; t < opt::kNumCostTerms; ++t) offset[t + 1] = offset[t] + (k[t] != 0 ? blocks(counts[t]) : 0);
  for (int t = 0; t < opt::kNumCostTerms; ++t)
    if (k[t] != 0 && counts[t])
      k_partial<<<blocks(counts[t]), kBlock, 0, s>>>(I.val[t].as<double>(), counts[t], I.part.as<double>() + offset[t]);
  SF_CUDA(cudaGetLastError());
  I.part_host.resize(size_t(offset[opt::kNumCostTerms]));
  if (!I.part_host.empty())
    SF_CUDA(cudaMemcpyAsync(I.part_host.data(), I.part.p, I.part_host.size() * sizeof(double), cudaMemcpyDeviceToHost, s));
  SF_CUDA(cudaStreamSynchronize(s));
  opt::CostValues t{};
  for (int q = 0; q < opt::kNumCostTerms; ++q) {
    for (int b = offset[q]; b < offset[q + 1]; ++b) t[q] += I.part_host[size_t(b)];
    if (k[q] != 0) I.cs->count_evaluation(opt::CostTerm(q));
  }
  if (terms) *terms = t;
  double total = t[0];
  for (int q = 1; q < opt::kNumCostTerms; ++q) total += t[q];
  return total;
}

}  // namespace seamfit::cuda
