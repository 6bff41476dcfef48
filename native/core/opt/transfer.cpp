#include "opt/transfer.hpp"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace seamfit::opt {

Vec3 closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c, double bary[3]) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  auto set = [&](double u, double v, double w) { bary[0] = u; bary[1] = v; bary[2] = w; };
  if (d1 <= 0 && d2 <= 0) { set(1, 0, 0); return a; }
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) { set(0, 1, 0); return b; }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    set(1 - v, v, 0);
    return a + v * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) { set(0, 0, 1); return c; }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    set(1 - w, 0, w);
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    set(0, 1 - w, w);
    return b + w * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  set(1 - v - w, v, w);
  return a + v * ab + w * ac;
}

namespace {

struct Box {
  double lo[3], hi[3];
  void reset() {
    for (int a = 0; a < 3; ++a) { lo[a] = std::numeric_limits<double>::infinity(); hi[a] = -lo[a]; }
  }
  void grow(Vec3 p) {
    const double q[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], q[a]); hi[a] = std::max(hi[a], q[a]); }
  }
  void grow(const Box& b) {
    for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], b.lo[a]); hi[a] = std::max(hi[a], b.hi[a]); }
  }
  double dist2(Vec3 p) const {
    const double dx = std::max(std::max(lo[0] - p.x, p.x - hi[0]), 0.0);
    const double dy = std::max(std::max(lo[1] - p.y, p.y - hi[1]), 0.0);
    const double dz = std::max(std::max(lo[2] - p.z, p.z - hi[2]), 0.0);
    return dx * dx + dy * dy + dz * dz;
  }
};

struct Node {
  Box box;
  int left = -1, right = -1;  // children, or -1 for a leaf
  int begin = 0, end = 0;     // leaf range of slots
};

// A triangle stored by value in BVH order ("slot"), so that spatially close triangles
// are close in memory.
struct SlotTri {
  Vec3 a, b, c;
  Box box;
};

// Axis-aligned bounding-volume hierarchy over the body triangles (median splits).
// Everything is indexed by slot; order[slot] is the original triangle id.
class Bvh {
 public:
  Bvh(const std::vector<Vec3>& v, const std::vector<std::array<int, 3>>& f) {
    const int nf = int(f.size());
    order.resize(nf);
    cent_.resize(nf);
    std::vector<Box> tbox(nf);
    for (int t = 0; t < nf; ++t) {
      order[t] = t;
      tbox[t].reset();
      for (int a = 0; a < 3; ++a) tbox[t].grow(v[f[t][a]]);
      cent_[t] = (1.0 / 3.0) * (v[f[t][0]] + v[f[t][1]] + v[f[t][2]]);
    }
    nodes_.reserve(2 * nf / kLeaf + 2);
    if (nf > 0) build(0, nf, tbox);
    tri.resize(nf);
    for (int s = 0; s < nf; ++s) {
      const auto& ft = f[order[s]];
      tri[s] = {v[ft[0]], v[ft[1]], v[ft[2]], tbox[order[s]]};
    }
  }

  double dist2(int s, Vec3 p, double bary[3]) const {
    return norm2(closest_point_on_triangle(p, tri[s].a, tri[s].b, tri[s].c, bary) - p);
  }

  // Closest slot and its squared distance.
  std::pair<int, double> nearest(Vec3 p) const {
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    int stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
      const Node& n = nodes_[stack[--sp]];
      if (n.box.dist2(p) >= best_d2) continue;
      if (n.left < 0) {
        for (int s = n.begin; s < n.end; ++s) {
          double bc[3];
          const double d2 = dist2(s, p, bc);
          if (d2 < best_d2) { best_d2 = d2; best = s; }
        }
      } else {
        // Visit the nearer child first (pushed last).
        const double dl = nodes_[n.left].box.dist2(p), dr = nodes_[n.right].box.dist2(p);
        if (dl < dr) { stack[sp++] = n.right; stack[sp++] = n.left; }
        else { stack[sp++] = n.left; stack[sp++] = n.right; }
      }
    }
    return {best, best_d2};
  }

  // Every slot whose bounding box is within r2 (squared) of p.
  template <class F>
  void within(Vec3 p, double r2, F&& visit) const {
    int stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
      const Node& n = nodes_[stack[--sp]];
      if (n.box.dist2(p) > r2) continue;
      if (n.left < 0) {
        for (int s = n.begin; s < n.end; ++s)
          if (tri[s].box.dist2(p) <= r2) visit(s);
      } else {
        stack[sp++] = n.left;
        stack[sp++] = n.right;
      }
    }
  }

  std::vector<int> order;
  std::vector<SlotTri> tri;

 private:
  static constexpr int kLeaf = 4;

  int build(int begin, int end, const std::vector<Box>& tbox) {
    const int id = int(nodes_.size());
    nodes_.emplace_back();
    Box box, cbox;
    box.reset();
    cbox.reset();
    for (int s = begin; s < end; ++s) { box.grow(tbox[order[s]]); cbox.grow(cent_[order[s]]); }
    nodes_[id].box = box;
    if (end - begin <= kLeaf) {
      nodes_[id].begin = begin;
      nodes_[id].end = end;
      return id;
    }
    int axis = 0;
    double ext = -1;
    for (int a = 0; a < 3; ++a)
      if (cbox.hi[a] - cbox.lo[a] > ext) { ext = cbox.hi[a] - cbox.lo[a]; axis = a; }
    const int mid = (begin + end) / 2;
    auto key = [&](int t) { return axis == 0 ? cent_[t].x : (axis == 1 ? cent_[t].y : cent_[t].z); };
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](int a, int b) { return key(a) < key(b); });
    const int l = build(begin, mid, tbox);
    const int r = build(mid, end, tbox);
    nodes_[id].left = l;
    nodes_[id].right = r;
    return id;
  }

  std::vector<Vec3> cent_;
  std::vector<Node> nodes_;
};

// 30-bit Morton code of a point in a box, to process spatially close queries together.
uint32_t morton(Vec3 p, const Box& b) {
  auto spread = [](uint32_t x) {
    x &= 0x3ff;
    x = (x | (x << 16)) & 0x30000ff;
    x = (x | (x << 8)) & 0x300f00f;
    x = (x | (x << 4)) & 0x30c30c3;
    x = (x | (x << 2)) & 0x9249249;
    return x;
  };
  const double q[3] = {p.x, p.y, p.z};
  uint32_t c[3];
  for (int a = 0; a < 3; ++a) {
    const double ext = b.hi[a] - b.lo[a];
    const double u = ext > 0 ? (q[a] - b.lo[a]) / ext : 0.0;
    c[a] = uint32_t(std::min(std::max(u, 0.0), 1.0) * 1023.0);
  }
  return spread(c[0]) | (spread(c[1]) << 1) | (spread(c[2]) << 2);
}

}  // namespace

std::vector<TransferHit> transfer_query(const std::vector<Vec3>& verts, const std::vector<std::array<int, 3>>& faces,
                                        const std::vector<Vec3>& points, double bandwidth) {
  if (!(bandwidth > 0)) throw std::invalid_argument("transfer bandwidth must be > 0");
  if (faces.empty()) throw std::invalid_argument("body has no triangles");
  const int nv = int(verts.size()), nf = int(faces.size()), np = int(points.size());
  for (const auto& f : faces)
    for (int v : f)
      if (v < 0 || v >= nv) throw std::invalid_argument("body face index out of range");

  const Bvh bvh(verts, faces);
  std::vector<int> slot_of(nf);
  for (int s = 0; s < nf; ++s) slot_of[bvh.order[s]] = s;

  // Slots sharing a vertex with each slot (CSR, including itself).
  std::vector<int> vt_off(nv + 1, 0), vt;
  for (const auto& f : faces)
    for (int v : f) ++vt_off[v + 1];
  for (int v = 0; v < nv; ++v) vt_off[v + 1] += vt_off[v];
  vt.resize(vt_off[nv]);
  {
    std::vector<int> fill(vt_off.begin(), vt_off.end() - 1);
    for (int t = 0; t < nf; ++t)
      for (int v : faces[t]) vt[fill[v]++] = slot_of[t];
  }
  std::vector<int> nb_off(nf + 1, 0), nb;
  nb.reserve(size_t(nf) * 13);
  {
    std::vector<int> l;
    for (int s = 0; s < nf; ++s) {
      l.clear();
      for (int v : faces[bvh.order[s]]) l.insert(l.end(), vt.begin() + vt_off[v], vt.begin() + vt_off[v + 1]);
      std::sort(l.begin(), l.end());
      l.erase(std::unique(l.begin(), l.end()), l.end());
      nb.insert(nb.end(), l.begin(), l.end());
      nb_off[s + 1] = int(nb.size());
    }
  }

  // Query order: along a Morton curve, so consecutive queries touch the same slots.
  Box pbox;
  pbox.reset();
  for (const Vec3& p : points) pbox.grow(p);
  std::vector<std::pair<uint32_t, int>> qorder(np);
  for (int i = 0; i < np; ++i) qorder[i] = {morton(points[i], pbox), i};
  std::sort(qorder.begin(), qorder.end());

  std::vector<TransferHit> hits(np);
  const double reach = 2.0 * bandwidth;

#pragma omp parallel
  {
    // Per-thread squared-distance table stamped by query, so lookups need no clearing.
    std::vector<int> stamp(nf, -1);
    std::vector<double> dist(nf, 0.0);
    std::vector<int> cand;
#pragma omp for schedule(dynamic, 256)
    for (int k = 0; k < np; ++k) {
      const int q = qorder[k].second;
      const Vec3 x = points[q];
      TransferHit& h = hits[q];
      const auto [s0, d02] = bvh.nearest(x);
      h.t0 = bvh.order[s0];
      bvh.dist2(s0, x, h.b0);
      h.d0 = std::sqrt(d02);
      // Squared distances throughout; square roots only for the two results.
      const double r = h.d0 + reach, r2 = r * r;
      cand.clear();
      bvh.within(x, r2, [&](int s) {
        double bc[3];
        const double d2 = bvh.dist2(s, x, bc);
        stamp[s] = q;
        dist[s] = d2;
        if (d2 <= r2) cand.push_back(s);
      });
      auto touches_t0 = [&](int s) {
        for (int i = nb_off[s0]; i < nb_off[s0 + 1]; ++i)
          if (nb[i] == s) return true;
        return false;
      };
      // The closest qualifying candidate: a linear scan, testing the (cheaper to reject)
      // distance first. Ties go to the lower slot, so the result is deterministic.
      double best = std::numeric_limits<double>::infinity();
      int best_s = -1;
      for (const int s : cand) {
        const double d = dist[s];
        if (d > best || (d == best && s > best_s)) continue;
        if (touches_t0(s)) continue;
        bool local_min = true;
        // A neighbour outside the gathered set is farther than r >= d, so never closer.
        for (int i = nb_off[s]; i < nb_off[s + 1] && local_min; ++i) {
          const int u = nb[i];
          if (stamp[u] == q && dist[u] < d) local_min = false;
        }
        if (!local_min) continue;
        best = d;
        best_s = s;
      }
      if (best_s >= 0) {
        h.t1 = bvh.order[best_s];
        h.d1 = std::sqrt(best);
        bvh.dist2(best_s, x, h.b1);
      }
    }
  }
  return hits;
}

}  // namespace seamfit::opt
