#include "body/sdf_build.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "body/tri_bvh.hpp"
#include "body/tri_distance.hpp"

namespace seamfit::body {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr float kFar = std::numeric_limits<float>::max();
constexpr uint64_t kEmpty = ~uint64_t(0);

inline uint64_t pack(float d, int32_t t) {
  uint32_t bits;
  std::memcpy(&bits, &d, 4);
  return (uint64_t(bits) << 32) | uint32_t(t);
}
inline float unpack_d(uint64_t c) {
  const uint32_t bits = uint32_t(c >> 32);
  float d;
  std::memcpy(&d, &bits, 4);
  return d;
}
inline int32_t unpack_t(uint64_t c) { return int32_t(uint32_t(c)); }
constexpr double kPi = 3.14159265358979323846;

struct Grid {
  double o[3];
  int64_t nx, ny, nz;
  double h;
  Vec3 node(int64_t i, int64_t j, int64_t k) const {
    return make_vec3(o[0] + h * double(i), o[1] + h * double(j), o[2] + h * double(k));
  }
  int64_t idx(int64_t i, int64_t j, int64_t k) const { return i + nx * (j + ny * k); }
  // Node index range [lo, hi] (inclusive, clipped) of positions in [a, b] along axis.
  void range(int axis, double a, double b, int64_t& lo, int64_t& hi) const {
    const int64_t n = axis == 0 ? nx : axis == 1 ? ny : nz;
    double fa = std::ceil((a - o[axis]) / h), fb = std::floor((b - o[axis]) / h);
    fa = std::max(fa, 0.0);
    fb = std::min(fb, double(n - 1));
    lo = int64_t(fa);
    hi = int64_t(fb);
  }
};

// Triangles bucketed by grid row k (CSR), for the band and the sign scan.
struct RowBuckets {
  std::vector<int64_t> start;
  std::vector<int32_t> items;
};

template <class RangeFn>
RowBuckets bucket_rows(int64_t n_items, int64_t nz, RangeFn range_k) {
  RowBuckets b;
  b.start.assign(nz + 1, 0);
  for (int64_t t = 0; t < n_items; ++t) {
    int64_t k0, k1;
    range_k(t, k0, k1);
    for (int64_t k = k0; k <= k1; ++k) ++b.start[k + 1];
  }
  for (int64_t k = 0; k < nz; ++k) b.start[k + 1] += b.start[k];
  b.items.resize(b.start[nz]);
  std::vector<int64_t> fill(b.start.begin(), b.start.end() - 1);
  for (int64_t t = 0; t < n_items; ++t) {
    int64_t k0, k1;
    range_k(t, k0, k1);
    for (int64_t k = k0; k <= k1; ++k) b.items[fill[k]++] = int32_t(t);
  }
  return b;
}

// ---------------------------------------------------------------- boundary caps

struct Cap {
  Vec3 centre;
  double eval_radius = 0;  // within it the cap's solid angle is evaluated exactly
};

// Net oriented boundary of the triangle chain: directed edges whose uses do not
// cancel. Each connected component is closed by a fan of triangles to its centroid
// (appended as extra vertices), oriented so that mesh + caps has no boundary.
void close_with_caps(std::vector<Vec3>& verts, const std::vector<int32_t>& faces_in, int64_t n_faces,
                     std::vector<int32_t>& cap_faces, std::vector<Cap>& caps, int64_t& n_boundary) {
  const int64_t nv = int64_t(verts.size());
  std::vector<std::pair<uint64_t, int>> edges;
  edges.reserve(size_t(3 * n_faces));
  for (int64_t f = 0; f < n_faces; ++f) {
    for (int e = 0; e < 3; ++e) {
      const uint64_t a = uint64_t(faces_in[3 * f + e]), b = uint64_t(faces_in[3 * f + (e + 1) % 3]);
      if (a == b) continue;
      edges.emplace_back(a < b ? a * uint64_t(nv) + b : b * uint64_t(nv) + a, a < b ? 1 : -1);
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<int64_t, int64_t>> bnd;  // directed boundary edges (with multiplicity)
  for (size_t s = 0; s < edges.size();) {
    size_t e = s;
    int net = 0;
    while (e < edges.size() && edges[e].first == edges[s].first) net += edges[e++].second;
    const int64_t lo = int64_t(edges[s].first / uint64_t(nv)), hi = int64_t(edges[s].first % uint64_t(nv));
    for (int m = 0; m < std::abs(net); ++m) bnd.emplace_back(net > 0 ? lo : hi, net > 0 ? hi : lo);
    s = e;
  }
  n_boundary = int64_t(bnd.size());
  if (bnd.empty()) return;
  // Union-find over boundary vertices: one cap per connected boundary component.
  std::vector<int64_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int64_t x) {
    while (parent[x] != x) { parent[x] = parent[parent[x]]; x = parent[x]; }
    return x;
  };
  for (auto& [a, b] : bnd) parent[find(a)] = find(b);
  std::vector<int64_t> comp_of(nv, -1);
  std::vector<int64_t> roots;
  for (auto& [a, b] : bnd) {
    const int64_t r = find(a);
    if (comp_of[r] < 0) { comp_of[r] = int64_t(roots.size()); roots.push_back(r); }
  }
  const size_t nc = roots.size();
  std::vector<Vec3> sum(nc, make_vec3(0, 0, 0));
  std::vector<int64_t> cnt(nc, 0);
  std::vector<char> seen(nv, 0);
  for (auto& [a, b] : bnd) {
    for (int64_t v : {a, b}) {
      if (seen[v]) continue;
      seen[v] = 1;
      const int64_t c = comp_of[find(v)];
      sum[c] += verts[v];
      ++cnt[c];
    }
  }
  caps.resize(nc);
  std::vector<double> radius(nc, 0), area(nc, 0);
  for (size_t c = 0; c < nc; ++c) caps[c].centre = (1.0 / double(cnt[c])) * sum[c];
  for (auto& [a, b] : bnd) {
    const int64_t c = comp_of[find(a)];
    const Vec3 cen = caps[c].centre;
    radius[c] = std::max({radius[c], norm(verts[a] - cen), norm(verts[b] - cen)});
    area[c] += 0.5 * norm(cross(verts[a] - cen, verts[b] - cen));
    // (b, a, centre) cancels the mesh's a->b; the spokes cancel around the loop.
    cap_faces.insert(cap_faces.end(), {int32_t(b), int32_t(a), int32_t(nv + c)});
  }
  // |solid angle of a surface of area A seen from distance d| <= A / d^2, so beyond
  // r_c + sqrt(A_total / (4 pi 0.4)) the caps together contribute |w| < 0.4 < 1/2.
  const double a_total = std::accumulate(area.begin(), area.end(), 0.0);
  const double reach = std::sqrt(a_total / (4.0 * kPi * 0.4));
  for (size_t c = 0; c < nc; ++c) {
    caps[c].eval_radius = radius[c] + reach;
    verts.push_back(caps[c].centre);
  }
}

double solid_angle(Vec3 a, Vec3 b, Vec3 c) {
  const double la = norm(a), lb = norm(b), lc = norm(c);
  const double num = dot(a, cross(b, c));
  const double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2.0 * std::atan2(num, den);
}

// ---------------------------------------------------------------- sign by ray crossings

struct Crossing {
  double x;
  int w;  // +1 entering (normal's x < 0), -1 leaving
  bool operator<(const Crossing& o) const { return x < o.x; }
};

// 2-D edge function of the directed edge u->v at q in the (y, z) plane, evaluated
// in a canonical vertex order so both triangles sharing an edge see bitwise
// opposite values.
inline double edge_fn(const std::vector<Vec3>& V, int32_t u, int32_t v, double qy, double qz) {
  const bool flip = u > v;
  const Vec3& P = V[flip ? v : u];
  const Vec3& Q = V[flip ? u : v];
  const double e = (Q.y - P.y) * (qz - P.z) - (Q.z - P.z) * (qy - P.y);
  return flip ? -e : e;
}

// Does the x-parallel line through (qy, qz) cross triangle f? On an exact tie with
// an edge, the edge counts for exactly one of the two (same-facing) triangles sharing
// it: the one for which the edge, walked with the interior on its left, points
// "up" (+z, or +y when horizontal).
inline bool line_crosses(const std::vector<Vec3>& V, const int32_t* f, double qy, double qz, double& x, int& w) {
  const Vec3 &A = V[f[0]], &B = V[f[1]], &C = V[f[2]];
  const double area = (B.y - A.y) * (C.z - A.z) - (B.z - A.z) * (C.y - A.y);
  if (area == 0 || !std::isfinite(area)) return false;
  const double sg = area > 0 ? 1.0 : -1.0;
  double lam[3];
  for (int e = 0; e < 3; ++e) {
    const int32_t u = f[e], v = f[(e + 1) % 3];
    const double s = sg * edge_fn(V, u, v, qy, qz);
    if (s < 0) return false;
    if (s == 0) {
      const double dy = sg * (V[v].y - V[u].y), dz = sg * (V[v].z - V[u].z);
      if (!(dz > 0 || (dz == 0 && dy > 0))) return false;
    }
    lam[(e + 2) % 3] = s;  // edge u->v is opposite vertex (e + 2) % 3
  }
  const double tot = lam[0] + lam[1] + lam[2];
  if (tot > 0) x = (lam[0] * A.x + lam[1] * B.x + lam[2] * C.x) / tot;
  else x = (A.x + B.x + C.x) / 3.0;  // q on a vertex: any point of the triangle's x range
  w = area > 0 ? -1 : 1;
  return true;
}

}  // namespace

// ---------------------------------------------------------------- layout

SdfLayout sdf_layout(const double* V, int64_t nv, const SdfBuildParams& p) {
  if (!(p.spacing > 0) || !std::isfinite(p.spacing)) throw std::invalid_argument("spacing must be a positive number of metres");
  if (!(p.padding >= 0) || !std::isfinite(p.padding)) throw std::invalid_argument("padding must be >= 0 metres");
  SdfLayout L;
  if (p.has_bounds) {
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(p.bounds_lo[a]) || !std::isfinite(p.bounds_hi[a]) || !(p.bounds_hi[a] > p.bounds_lo[a]))
        throw std::invalid_argument("bounds must be finite with max > min on every axis");
      L.origin[a] = p.bounds_lo[a];
      const double cells = std::ceil((p.bounds_hi[a] - p.bounds_lo[a]) / p.spacing - 1e-9);
      L.dims[a] = std::max<int64_t>(2, int64_t(cells) + 1);
    }
    return L;
  }
  if (nv <= 0) throw std::invalid_argument("the mesh has no vertices");
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int64_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], V[3 * v + a]);
      hi[a] = std::max(hi[a], V[3 * v + a]);
    }
  for (int a = 0; a < 3; ++a) {
    const double ext = hi[a] - lo[a] + 2 * p.padding;
    const double cells = std::ceil(ext / p.spacing - 1e-9);
    L.dims[a] = std::max<int64_t>(2, int64_t(cells) + 1);
    // Centred, so a mirror-symmetric body gets a mirror-symmetric grid.
    L.origin[a] = 0.5 * (lo[a] + hi[a]) - 0.5 * double(L.dims[a] - 1) * p.spacing;
  }
  return L;
}

namespace {

// Phases 1 and 2 on the CPU: unsigned distances of every node into out.
void cpu_distances(const Grid& G, const std::vector<TriPre>& tris, const std::vector<Vec3>& verts,
                   const SdfBuildParams& P, int nt, SdfBuildStats& st, float* out) {
  const double h = G.h;
  const int64_t nf = int64_t(tris.size());
  const int64_t N = G.nx * G.ny * G.nz;

  // Working state per node: distance and closest triangle packed in one word
  // (float bits high, triangle low). Distances are >= 0, so comparing packed
  // words compares distances, and one atomic word keeps the pair consistent.
  std::vector<uint64_t> cell(N, kEmpty);

  // ---- 1. exact narrow band
  auto t0 = Clock::now();
  const double pad = P.band * h;
  auto tri_range = [&](int64_t t, int axis, int64_t& lo, int64_t& hi) {
    const TriPre& T = tris[t];
    const double c[3][3] = {{T.a[0], T.b[0], T.c[0]}, {T.a[1], T.b[1], T.c[1]}, {T.a[2], T.b[2], T.c[2]}};
    const double mn = std::min({c[axis][0], c[axis][1], c[axis][2]}) - pad;
    const double mx = std::max({c[axis][0], c[axis][1], c[axis][2]}) + pad;
    G.range(axis, mn, mx, lo, hi);
  };
  {
    RowBuckets rows = bucket_rows(nf, G.nz, [&](int64_t t, int64_t& k0, int64_t& k1) { tri_range(t, 2, k0, k1); });
    int64_t evals = 0;
#pragma omp parallel for num_threads(nt) schedule(dynamic, 1) reduction(+ : evals)
    for (int64_t k = 0; k < G.nz; ++k) {  // one plane per thread: no races
      for (int64_t q = rows.start[k]; q < rows.start[k + 1]; ++q) {
        const int32_t t = rows.items[q];
        int64_t i0, i1, j0, j1;
        tri_range(t, 0, i0, i1);
        tri_range(t, 1, j0, j1);
        for (int64_t j = j0; j <= j1; ++j) {
          for (int64_t i = i0; i <= i1; ++i) {
            const int64_t id = G.idx(i, j, k);
            const uint64_t c = pack(float(std::sqrt(tri_dist2(tris[t], G.node(i, j, k)))), t);
            if (c < cell[id]) cell[id] = c;
          }
          evals += i1 >= i0 ? i1 - i0 + 1 : 0;
        }
      }
    }
    st.band_evaluations = evals;
  }
  st.seconds_band = seconds_since(t0);

  // ---- 1b. bounds that cut the mesh: seed the border with exact nearest triangles
  t0 = Clock::now();
  bool mesh_inside = true;
  for (const Vec3& v : verts) {
    if (v.x < G.o[0] || v.y < G.o[1] || v.z < G.o[2] || v.x > G.o[0] + h * double(G.nx - 1) ||
        v.y > G.o[1] + h * double(G.ny - 1) || v.z > G.o[2] + h * double(G.nz - 1)) { mesh_inside = false; break; }
  }
  if (!mesh_inside) {
    const TriBvh bvh = build_tri_bvh(tris);
    int64_t seeded = 0;
#pragma omp parallel for num_threads(nt) schedule(dynamic, 1) reduction(+ : seeded)
    for (int64_t k = 0; k < G.nz; ++k) {
      const bool cap_plane = k == 0 || k == G.nz - 1;
      for (int64_t j = 0; j < G.ny; ++j) {
        const bool full_row = cap_plane || j == 0 || j == G.ny - 1;
        const int64_t step = full_row ? 1 : G.nx - 1;
        for (int64_t i = 0; i < G.nx; i += step) {
          const int64_t id = G.idx(i, j, k);
          double best = 1e300;
          int32_t bt = -1;
          if (cell[id] != kEmpty) {
            best = double(unpack_d(cell[id])) * double(unpack_d(cell[id]));
            bt = unpack_t(cell[id]);
          }
          bvh_nearest(bvh.nodes.data(), bvh.order.data(), tris.data(), G.node(i, j, k), best, bt);
          cell[id] = pack(float(std::sqrt(best)), bt);
          ++seeded;
        }
      }
    }
    st.seeded_nodes = seeded;
  }
  st.seconds_seed = seconds_since(t0);

  // ---- 2. closest-triangle propagation by sweeps
  // A pass walks the z planes upward, a second one downward. Each plane first tries
  // the triangles of the plane before it, then sweeps within the plane: along y
  // forward, along x both ways, along y backward, along x both ways. Each of those
  // loops runs its independent units at once on every thread - the nodes of the plane
  // (reading the plane before), blocks of whole columns (a y sweep), whole rows (an x
  // sweep) - and a unit reads only what the loop leaves unwritten or its own unit, so
  // the field is the same bits for any thread count or timing.
  t0 = Clock::now();
  {
    const int64_t sz = G.nx * G.ny;
    // Columns per block of a y sweep: fixed (not from the thread count), a few cache
    // lines of each row.
    const int64_t col_block = 16;
    const int64_t n_blocks = (G.nx + col_block - 1) / col_block;
    int64_t evals = 0;
    auto relax = [&](int64_t src, int64_t dst, const Vec3& p, int64_t& cnt) {
      const uint64_t s = cell[src];
      if (s == kEmpty) return;
      const uint64_t cur = cell[dst];
      const uint32_t t = uint32_t(s);
      if (uint32_t(cur) == t) return;
      // dist(p, t) >= dist(src, t) - h: skip triangles that cannot win.
      if (cur != kEmpty && double(unpack_d(s)) - h >= double(unpack_d(cur))) return;
      const TriPre& T = tris[t];
      if (cur != kEmpty) {
        // Cheap lower bounds first: distance to the triangle's plane, and to its
        // bounding sphere.
        const double dc = double(unpack_d(cur));
        const double pl = dot(p - tri_vec(T.a), tri_vec(T.n));
        if (pl * pl >= dc * dc) return;
        const double rc = dc + double(T.radius);
        if (norm2(p - tri_vec(T.centre)) >= rc * rc) return;
      }
      ++cnt;
      const uint64_t c = pack(float(std::sqrt(tri_dist2(T, p))), int32_t(t));
      if (c < cur) cell[dst] = c;
    };
    auto node = [&](int64_t i, int64_t j, int64_t k) {
      return make_vec3(G.o[0] + h * double(i), G.o[1] + h * double(j), G.o[2] + h * double(k));
    };
    for (int round = 0; round < P.rounds; ++round) {
      for (int dir : {1, -1}) {
        for (int64_t step = 0; step < G.nz; ++step) {
          const int64_t k = dir > 0 ? step : G.nz - 1 - step;
#pragma omp parallel num_threads(nt) reduction(+ : evals)
          {
            if (step > 0) {
              const int64_t prev = -dir * sz;
#pragma omp for schedule(static)
              for (int64_t j = 0; j < G.ny; ++j)
                for (int64_t i = 0; i < G.nx; ++i) relax(G.idx(i, j, k) + prev, G.idx(i, j, k), node(i, j, k), evals);
            }
            for (int ydir : {1, -1}) {
#pragma omp for schedule(static)
              for (int64_t bl = 0; bl < n_blocks; ++bl) {
                const int64_t i0 = bl * col_block, i1 = std::min(G.nx, i0 + col_block);
                for (int64_t s = 1; s < G.ny; ++s) {
                  const int64_t j = ydir > 0 ? s : G.ny - 1 - s;
                  for (int64_t i = i0; i < i1; ++i)
                    relax(G.idx(i, j - ydir, k), G.idx(i, j, k), node(i, j, k), evals);
                }
              }
#pragma omp for schedule(static)
              for (int64_t j = 0; j < G.ny; ++j) {
                const int64_t base = G.idx(0, j, k);
                for (int64_t i = 1; i < G.nx; ++i) relax(base + i - 1, base + i, node(i, j, k), evals);
                for (int64_t i = G.nx - 2; i >= 0; --i) relax(base + i + 1, base + i, node(i, j, k), evals);
              }
            }
          }
        }
      }
    }
    st.propagate_evaluations = evals;
  }
  st.seconds_propagate = seconds_since(t0);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (int64_t q = 0; q < N; ++q) out[q] = cell[q] == kEmpty ? kFar : unpack_d(cell[q]);
  std::vector<uint64_t>().swap(cell);
}

}  // namespace

// ---------------------------------------------------------------- build

SdfBuildStats sdf_build(const double* Vin, int64_t nv, const int32_t* Fin, int64_t nf, const SdfLayout& L,
                        const SdfBuildParams& P, float* out) {
  const auto t_start = Clock::now();
  SdfBuildStats st;
  const int nt = P.threads > 0 ? P.threads : omp_get_max_threads();
  st.threads = nt;
  if (nf <= 0) throw std::invalid_argument("the mesh has no faces");
  if (nv >= (int64_t(1) << 30)) throw std::invalid_argument("too many vertices (at most 2^30)");
  for (int64_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(Vin[3 * v + a]))
        throw std::invalid_argument("vertex " + std::to_string(v) + " has a non-finite coordinate");
  for (int64_t f = 0; f < 3 * nf; ++f)
    if (Fin[f] < 0 || Fin[f] >= nv)
      throw std::invalid_argument("face " + std::to_string(f / 3) + " refers to vertex " + std::to_string(Fin[f]) +
                                  " (the mesh has " + std::to_string(nv) + " vertices)");
  if (L.dims[0] < 2 || L.dims[1] < 2 || L.dims[2] < 2) throw std::invalid_argument("grid needs at least 2 nodes per axis");
  if (P.gpu && !P.gpu_distances)
    throw std::invalid_argument("device cuda: this build has no CUDA backend for the SDF (it was built without nvcc)");

  const double h = P.spacing;
  // Work in a frame centred on the grid: smaller coordinates, smaller rounding.
  double shift[3];
  for (int a = 0; a < 3; ++a) shift[a] = L.origin[a] + 0.5 * h * double(L.dims[a] - 1);
  Grid G{{L.origin[0] - shift[0], L.origin[1] - shift[1], L.origin[2] - shift[2]}, L.dims[0], L.dims[1], L.dims[2], h};

  std::vector<Vec3> verts(nv);
  for (int64_t v = 0; v < nv; ++v)
    verts[v] = make_vec3(Vin[3 * v] - shift[0], Vin[3 * v + 1] - shift[1], Vin[3 * v + 2] - shift[2]);
  std::vector<int32_t> faces(Fin, Fin + 3 * nf);
  // Triangles in Morton order of their centroids: triangles that are near in
  // space are near in memory, so the random lookups of propagation hit the cache.
  std::vector<TriPre> tris(nf);
  {
    std::vector<std::pair<uint64_t, int32_t>> key(nf);
    const double scale = 1023.0 / (h * double(std::max({G.nx, G.ny, G.nz})));
    for (int64_t f = 0; f < nf; ++f) {
      const Vec3 c = (1.0 / 3.0) * (verts[faces[3 * f]] + verts[faces[3 * f + 1]] + verts[faces[3 * f + 2]]);
      const double q[3] = {(c.x - G.o[0]) * scale, (c.y - G.o[1]) * scale, (c.z - G.o[2]) * scale};
      uint64_t code = 0;
      for (int a = 0; a < 3; ++a) {
        const uint64_t v = uint64_t(std::clamp(q[a], 0.0, 1023.0));
        for (int b = 0; b < 10; ++b) code |= ((v >> b) & 1u) << (3 * b + a);
      }
      key[f] = {code, int32_t(f)};
    }
    std::sort(key.begin(), key.end());
    for (int64_t f = 0; f < nf; ++f) {
      const int32_t* g = &faces[3 * key[f].second];
      tris[f] = make_tri(verts[g[0]], verts[g[1]], verts[g[2]]);
    }
  }

  auto t0 = Clock::now();
  if (P.gpu) {
    // Exact nearest distances of every node on the GPU, from a BVH built here.
    const TriBvh bvh = build_tri_bvh(tris);
    SdfGpuInput in;
    in.tris = tris.data();
    in.n_tris = nf;
    in.nodes = bvh.nodes.data();
    in.n_nodes = int64_t(bvh.nodes.size());
    in.order = bvh.order.data();
    for (int a = 0; a < 3; ++a) in.origin[a] = G.o[a];
    in.spacing = h;
    in.dims[0] = G.nx;
    in.dims[1] = G.ny;
    in.dims[2] = G.nz;
    P.gpu_distances(in, out);
    st.seconds_gpu = seconds_since(t0);
  } else {
    cpu_distances(G, tris, verts, P, nt, st, out);
  }

  // ---- 3. sign: winding numbers along x lines
  t0 = Clock::now();
  std::vector<int32_t> cap_faces;
  std::vector<Cap> caps;
  int64_t n_boundary = 0;
  close_with_caps(verts, faces, nf, cap_faces, caps, n_boundary);
  st.boundary_edges = n_boundary;
  st.caps = int64_t(caps.size());
  const int64_t n_cap = int64_t(cap_faces.size() / 3);
  faces.insert(faces.end(), cap_faces.begin(), cap_faces.end());
  const int64_t n_all = nf + n_cap;
  auto yz_range = [&](int64_t t, int axis, int64_t& lo, int64_t& hi) {
    const int32_t* f = &faces[3 * t];
    const double c0 = axis == 1 ? verts[f[0]].y : verts[f[0]].z;
    const double c1 = axis == 1 ? verts[f[1]].y : verts[f[1]].z;
    const double c2 = axis == 1 ? verts[f[2]].y : verts[f[2]].z;
    G.range(axis, std::min({c0, c1, c2}), std::max({c0, c1, c2}), lo, hi);
  };
  RowBuckets rows = bucket_rows(n_all, G.nz, [&](int64_t t, int64_t& k0, int64_t& k1) { yz_range(t, 2, k0, k1); });
  int64_t inside_total = 0, cap_nodes = 0;
#pragma omp parallel num_threads(nt) reduction(+ : inside_total, cap_nodes)
  {
    std::vector<std::vector<Crossing>> per_j(G.ny);
    std::vector<std::pair<int64_t, int64_t>> spans;
#pragma omp for schedule(dynamic, 1)
    for (int64_t k = 0; k < G.nz; ++k) {
      const double qz = G.o[2] + h * double(k);
      for (auto& v : per_j) v.clear();
      for (int64_t q = rows.start[k]; q < rows.start[k + 1]; ++q) {
        const int32_t t = rows.items[q];
        int64_t j0, j1;
        yz_range(t, 1, j0, j1);
        for (int64_t j = j0; j <= j1; ++j) {
          double x;
          int w;
          if (line_crosses(verts, &faces[3 * t], G.o[1] + h * double(j), qz, x, w)) per_j[j].push_back({x, w});
        }
      }
      for (int64_t j = 0; j < G.ny; ++j) {
        auto& cr = per_j[j];
        const double qy = G.o[1] + h * double(j);
        // Node spans where the caps' solid angle must be evaluated.
        spans.clear();
        for (const Cap& c : caps) {
          const double dy = qy - c.centre.y, dz = qz - c.centre.z;
          const double r2 = c.eval_radius * c.eval_radius - dy * dy - dz * dz;
          if (r2 <= 0) continue;
          const double r = std::sqrt(r2);
          int64_t a, b;
          G.range(0, c.centre.x - r, c.centre.x + r, a, b);
          if (a <= b) spans.emplace_back(a, b);
        }
        if (cr.empty() && spans.empty()) continue;
        std::sort(cr.begin(), cr.end());
        std::sort(spans.begin(), spans.end());
        size_t c = 0, s = 0;
        int wsum = 0;
        const int64_t base = G.idx(0, j, k);
        for (int64_t i = 0; i < G.nx; ++i) {
          const double x = G.o[0] + h * double(i);
          while (c < cr.size() && cr[c].x < x) wsum += cr[c++].w;
          while (s < spans.size() && spans[s].second < i) ++s;
          double w = double(wsum);
          bool in_span = false;
          for (size_t s2 = s; s2 < spans.size() && spans[s2].first <= i; ++s2)
            if (spans[s2].second >= i) { in_span = true; break; }
          if (in_span) {
            const Vec3 p = make_vec3(x, qy, qz);
            double omega = 0;
            for (int64_t t = nf; t < n_all; ++t) {
              const int32_t* f = &faces[3 * t];
              omega += solid_angle(verts[f[0]] - p, verts[f[1]] - p, verts[f[2]] - p);
            }
            w -= omega / (4.0 * kPi);
            ++cap_nodes;
          }
          if (w > 0.5) { out[base + i] = -out[base + i]; ++inside_total; }
        }
      }
    }
  }
  st.inside_nodes = inside_total;
  st.cap_winding_nodes = cap_nodes;
  st.seconds_sign = seconds_since(t0);
  st.seconds_total = seconds_since(t_start);
  return st;
}

}  // namespace seamfit::body
