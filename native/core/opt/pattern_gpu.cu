#include "opt/pattern_gpu.hpp"

#include <cuda_runtime.h>

#include <stdexcept>
#include <vector>

#include "device/dense_rows.cuh"
#include "device/dev_buffer.cuh"
#include "sim/sim_gpu.hpp"

namespace seamfit::cuda {

namespace {

// dtheta in block order: theta[perm[c]] - theta_bar[perm[c]].
__global__ void k_dtheta(int nb, const int32_t* perm, const double* theta, const double* theta_bar, double* out) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= nb) return;
  const int j = perm[c];
  out[2 * c] = theta[2 * j] - theta_bar[2 * j];
  out[2 * c + 1] = theta[2 * j + 1] - theta_bar[2 * j + 1];
}

// p: interior rows (stacked order, vertex vrow[r]) get pbar + y; boundary entries get theta.
__global__ void k_scatter_pattern(int ni, int nb, const int32_t* vrow, const int32_t* vb, const double* pbar,
                                  const double* y, const double* theta, double* p) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < ni) {
    const int v = vrow[k];
    p[2 * v] = pbar[2 * v] + y[2 * k];
    p[2 * v + 1] = pbar[2 * v + 1] + y[2 * k + 1];
  } else if (k < ni + nb) {
    const int j = k - ni, v = vb[j];
    p[2 * v] = theta[2 * j];
    p[2 * v + 1] = theta[2 * j + 1];
  }
}

// g at the interior rows, in stacked order.
__global__ void k_gather_rows(int ni, const int32_t* vrow, const double* g, double* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= ni) return;
  out[2 * k] = g[2 * vrow[k]];
  out[2 * k + 1] = g[2 * vrow[k] + 1];
}

// g_theta[perm[c]] = g at its boundary vertex + z[c].
__global__ void k_scatter_theta(int nb, const int32_t* perm, const int32_t* vb, const double* g, const double* z,
                                double* gt) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= nb) return;
  const int j = perm[c], v = vb[j];
  gt[2 * j] = g[2 * v] + z[2 * c];
  gt[2 * j + 1] = g[2 * v + 1] + z[2 * c + 1];
}

unsigned grid(int64_t n, int per_block) { return unsigned((n + per_block - 1) / per_block); }

}  // namespace

struct PatternGpu::Impl {
  cudaStream_t stream = nullptr;
  int n = 0, ni = 0, nb = 0;
  // Forward: rows = interior vertices panel by panel; adjoint: rows = theta entries panel by panel.
  DevBuf A_fwd, A_adj, f_block, f_row0, f_col0, f_ncols, f_off, a_block, a_row0, a_col0, a_ncols, a_off;
  DevBuf vrow, perm, vb, pbar, theta_bar, theta, dtheta, y, p, g, gI, z, gt;
  DenseRows fwd, adj;  // the two products, their buffers bound once
  DenseRows rows_of(const DevBuf& block, const DevBuf& row0, const DevBuf& col0, const DevBuf& ncols,
                    const DevBuf& off, const DevBuf& A, int rows, const DevBuf& in, DevBuf& out) const {
    DenseRows d;
    d.rows = rows;
    d.row_block = block.as<int32_t>();
    d.row0 = row0.as<int32_t>();
    d.col0 = col0.as<int32_t>();
    d.ncols = ncols.as<int32_t>();
    d.offset = off.as<int64_t>();
    d.A = A.as<double>();
    d.in = in.as<double>();
    d.out = out.as<double>();
    return d;
  }
  void launch(const DenseRows& d) const { launch_dense_rows<2>(d, stream); }
  // A host call of a device map: n_in rows of 2 up into `din`, map(din, dout), n_out rows back.
  template <class Map>
  void on_host(DevBuf& din, const Vec2* in, int n_in, DevBuf& dout, Vec2* out, int n_out, Map&& map) {
    upload(din, reinterpret_cast<const double*>(in), 2 * size_t(n_in), stream);
    map(din.as<double>(), dout.as<double>());
    SF_CUDA(cudaMemcpyAsync(out, dout.p, 2 * size_t(n_out) * sizeof(double), cudaMemcpyDeviceToHost, stream));
    SF_CUDA(cudaStreamSynchronize(stream));
  }
  ~Impl() {
    if (stream) cudaStreamDestroy(stream);
  }
};

PatternGpu::PatternGpu(const opt::Parametrization& param, size_t max_bytes) : impl_(new Impl) {
  Impl& I = *impl_;
  I.n = param.n_vertices();
  I.ni = int(param.interior_ids().size());
  I.nb = param.n_boundary();
  const size_t bytes = 2 * param.harmonic_doubles() * sizeof(double);
  size_t free_b = 0, total_b = 0;
  SF_CUDA(cudaMemGetInfo(&free_b, &total_b));
  if (bytes > max_bytes || bytes > free_b / 2)
    throw CudaError("the pattern's interior blocks need " + std::to_string(bytes >> 20) + " MiB of GPU memory (limit " +
                    std::to_string(std::min(max_bytes, free_b / 2) >> 20) + " MiB)");
  SF_CUDA(cudaStreamCreateWithFlags(&I.stream, cudaStreamNonBlocking));
  const std::vector<opt::Parametrization::HarmonicBlock> blocks = param.harmonic_blocks();
  const std::vector<int>& interior = param.interior_ids();
  const std::vector<int>& boundary = param.boundary_ids();
  std::vector<double> Af, Aa;
  Af.reserve(bytes / 16);
  Aa.reserve(bytes / 16);
  std::vector<int32_t> fb, fr0, fc0, fnc, ab, ar0, ac0, anc, vrow, perm;
  std::vector<int64_t> fo, ao;
  int rows_f = 0, rows_a = 0;
  for (const auto& B : blocks) {
    const int ni = int(B.rows.size()), nb = int(B.cols.size());
    if (nb == 0) continue;
    const int bf = int(fr0.size());
    // Forward block: ni rows of nb columns; its input: this panel's theta entries, from rows_a on.
    fr0.push_back(rows_f);
    fc0.push_back(rows_a);
    fnc.push_back(nb);
    fo.push_back(int64_t(Af.size()));
    Af.insert(Af.end(), B.M.begin(), B.M.end());
    // Adjoint block: its transpose, nb rows of ni columns; its input: this panel's interior rows.
    ar0.push_back(rows_a);
    ac0.push_back(rows_f);
    anc.push_back(ni);
    ao.push_back(int64_t(Aa.size()));
    for (int c = 0; c < nb; ++c)
      for (int r = 0; r < ni; ++r) Aa.push_back(B.M[size_t(r) * nb + c]);
    for (int r = 0; r < ni; ++r) {
      fb.push_back(bf);
      vrow.push_back(interior[B.rows[r]]);
    }
    for (int c = 0; c < nb; ++c) {
      ab.push_back(bf);
      perm.push_back(B.cols[c]);
    }
    rows_f += ni;
    rows_a += nb;
  }
  if (rows_f != I.ni || rows_a != I.nb) throw CudaError("the pattern's panels do not cover its vertices");
  std::vector<int32_t> vb(boundary.begin(), boundary.end());
  std::vector<double> pbar(2 * size_t(I.n)), tbar(2 * size_t(I.nb));
  for (int v = 0; v < I.n; ++v) {
    pbar[2 * v] = param.pbar()[v].x;
    pbar[2 * v + 1] = param.pbar()[v].y;
  }
  for (int j = 0; j < I.nb; ++j) {
    tbar[2 * j] = pbar[2 * boundary[j]];
    tbar[2 * j + 1] = pbar[2 * boundary[j] + 1];
  }
  cudaStream_t s = I.stream;
  upload(I.A_fwd, Af.data(), Af.size(), s);
  upload(I.A_adj, Aa.data(), Aa.size(), s);
  upload(I.f_block, fb.data(), fb.size(), s);
  upload(I.f_row0, fr0.data(), fr0.size(), s);
  upload(I.f_col0, fc0.data(), fc0.size(), s);
  upload(I.f_ncols, fnc.data(), fnc.size(), s);
  upload(I.f_off, fo.data(), fo.size(), s);
  upload(I.a_block, ab.data(), ab.size(), s);
  upload(I.a_row0, ar0.data(), ar0.size(), s);
  upload(I.a_col0, ac0.data(), ac0.size(), s);
  upload(I.a_ncols, anc.data(), anc.size(), s);
  upload(I.a_off, ao.data(), ao.size(), s);
  upload(I.vrow, vrow.data(), vrow.size(), s);
  upload(I.perm, perm.data(), perm.size(), s);
  upload(I.vb, vb.data(), vb.size(), s);
  upload(I.pbar, pbar.data(), pbar.size(), s);
  upload(I.theta_bar, tbar.data(), tbar.size(), s);
  for (DevBuf* b : {&I.theta, &I.dtheta, &I.z, &I.gt}) b->reserve(2 * size_t(std::max(I.nb, 1)) * sizeof(double));
  for (DevBuf* b : {&I.y, &I.gI}) b->reserve(2 * size_t(std::max(I.ni, 1)) * sizeof(double));
  for (DevBuf* b : {&I.p, &I.g}) b->reserve(2 * size_t(std::max(I.n, 1)) * sizeof(double));
  I.fwd = I.rows_of(I.f_block, I.f_row0, I.f_col0, I.f_ncols, I.f_off, I.A_fwd, I.ni, I.dtheta, I.y);
  I.adj = I.rows_of(I.a_block, I.a_row0, I.a_col0, I.a_ncols, I.a_off, I.A_adj, I.nb, I.gI, I.z);
  SF_CUDA(cudaStreamSynchronize(s));  // the host vectors go out of scope
}

PatternGpu::~PatternGpu() = default;

void PatternGpu::pattern(const Vec2* theta, Vec2* p) {
  Impl& I = *impl_;
  I.on_host(I.theta, theta, I.nb, I.p, p, I.n, [&](const double* t, double* q) { pattern_device(t, q); });
}

void PatternGpu::pattern_device(const double* d_theta, double* d_p) {
  Impl& I = *impl_;
  // The scatter writes p while other threads still read theta.
  if (d_p == d_theta) throw std::invalid_argument("pattern_device: p must not overwrite theta");
  cudaStream_t s = I.stream;
  if (I.nb) k_dtheta<<<grid(I.nb, 256), 256, 0, s>>>(I.nb, I.perm.as<int32_t>(), d_theta, I.theta_bar.as<double>(),
                                                     I.dtheta.as<double>());
  I.launch(I.fwd);
  if (I.ni + I.nb)
    k_scatter_pattern<<<grid(I.ni + I.nb, 256), 256, 0, s>>>(I.ni, I.nb, I.vrow.as<int32_t>(), I.vb.as<int32_t>(),
                                                             I.pbar.as<double>(), I.y.as<double>(), d_theta, d_p);
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaStreamSynchronize(s));
}

void PatternGpu::adjoint(const Vec2* g, Vec2* g_theta) {
  Impl& I = *impl_;
  I.on_host(I.g, g, I.n, I.gt, g_theta, I.nb, [&](const double* v, double* w) { adjoint_device(v, w); });
}

void PatternGpu::adjoint_device(const double* d_g, double* d_g_theta) {
  Impl& I = *impl_;
  // The scatter writes g_theta while other threads still read g.
  if (d_g_theta == d_g) throw std::invalid_argument("adjoint_device: g_theta must not overwrite g");
  cudaStream_t s = I.stream;
  if (I.ni) k_gather_rows<<<grid(I.ni, 256), 256, 0, s>>>(I.ni, I.vrow.as<int32_t>(), d_g, I.gI.as<double>());
  I.launch(I.adj);
  if (I.nb)
    k_scatter_theta<<<grid(I.nb, 256), 256, 0, s>>>(I.nb, I.perm.as<int32_t>(), I.vb.as<int32_t>(), d_g,
                                                     I.z.as<double>(), d_g_theta);
  SF_CUDA(cudaGetLastError());
  SF_CUDA(cudaStreamSynchronize(s));
}

size_t PatternGpu::device_bytes() const {
  const Impl& I = *impl_;
  return I.A_fwd.bytes + I.A_adj.bytes;
}

}  // namespace seamfit::cuda
