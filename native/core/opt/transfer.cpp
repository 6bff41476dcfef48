#include "opt/transfer.hpp"

#include <algorithm>
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
    const double q[3] = {p.x, p.y, p.z};
    double s = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = q[a] < lo[a] ? lo[a] - q[a] : (q[a] > hi[a] ? q[a] - hi[a] : 0);
      s += d * d;
    }
    return s;
  }
};

struct Node {
  Box box;
  int left = -1, right = -1;  // children, or -1 for a leaf
  int begin = 0, end = 0;     // leaf range in the permuted triangle order
};

// Axis-aligned bounding-volume hierarchy over the body triangles (median splits).
class Bvh {
 public:
  Bvh(const std::vector<Vec3>& v, const std::vector<std::array<int, 3>>& f) : v_(v), f_(f) {
    const int nf = int(f.size());
    order_.resize(nf);
    cent_.resize(nf);
    tbox_.resize(nf);
    for (int t = 0; t < nf; ++t) {
      order_[t] = t;
      tbox_[t].reset();
      for (int a = 0; a < 3; ++a) tbox_[t].grow(v[f[t][a]]);
      cent_[t] = (1.0 / 3.0) * (v[f[t][0]] + v[f[t][1]] + v[f[t][2]]);
    }
    nodes_.reserve(2 * nf / kLeaf + 2);
    if (nf > 0) build(0, nf);
  }

  // Closest triangle; returns its index and squared distance.
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
          const int t = order_[s];
          double bc[3];
          const Vec3 q = closest_point_on_triangle(p, v_[f_[t][0]], v_[f_[t][1]], v_[f_[t][2]], bc);
          const double d2 = norm2(q - p);
          if (d2 < best_d2) { best_d2 = d2; best = t; }
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

  // Every triangle whose bounding box is within r2 (squared) of p.
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
          if (tbox_[order_[s]].dist2(p) <= r2) visit(order_[s]);
      } else {
        stack[sp++] = n.left;
        stack[sp++] = n.right;
      }
    }
  }

 private:
  static constexpr int kLeaf = 4;

  int build(int begin, int end) {
    const int id = int(nodes_.size());
    nodes_.emplace_back();
    Box box, cbox;
    box.reset();
    cbox.reset();
    for (int s = begin; s < end; ++s) { box.grow(tbox_[order_[s]]); cbox.grow(cent_[order_[s]]); }
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
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](int a, int b) { return key(a) < key(b); });
    const int l = build(begin, mid);
    const int r = build(mid, end);
    nodes_[id].left = l;
    nodes_[id].right = r;
    return id;
  }

  const std::vector<Vec3>& v_;
  const std::vector<std::array<int, 3>>& f_;
  std::vector<int> order_;
  std::vector<Vec3> cent_;
  std::vector<Box> tbox_;
  std::vector<Node> nodes_;
};

}  // namespace

std::vector<TransferHit> transfer_query(const std::vector<Vec3>& verts, const std::vector<std::array<int, 3>>& faces,
                                        const std::vector<Vec3>& points, double bandwidth) {
  if (!(bandwidth > 0)) throw std::invalid_argument("transfer bandwidth must be > 0");
  if (faces.empty()) throw std::invalid_argument("body has no triangles");
  const int nv = int(verts.size()), nf = int(faces.size()), np = int(points.size());
  for (const auto& f : faces)
    for (int v : f)
      if (v < 0 || v >= nv) throw std::invalid_argument("body face index out of range");

  // Triangles sharing a vertex with each triangle (CSR, including itself).
  std::vector<int> vt_off(nv + 1, 0), vt;
  for (const auto& f : faces)
    for (int v : f) ++vt_off[v + 1];
  for (int v = 0; v < nv; ++v) vt_off[v + 1] += vt_off[v];
  vt.resize(vt_off[nv]);
  {
    std::vector<int> fill(vt_off.begin(), vt_off.end() - 1);
    for (int t = 0; t < nf; ++t)
      for (int v : faces[t]) vt[fill[v]++] = t;
  }
  std::vector<int> nb_off(nf + 1, 0), nb;
  {
    std::vector<std::vector<int>> tmp(nf);
    for (int t = 0; t < nf; ++t) {
      auto& l = tmp[t];
      for (int v : faces[t]) l.insert(l.end(), vt.begin() + vt_off[v], vt.begin() + vt_off[v + 1]);
      std::sort(l.begin(), l.end());
      l.erase(std::unique(l.begin(), l.end()), l.end());
      nb_off[t + 1] = nb_off[t] + int(l.size());
    }
    nb.reserve(nb_off[nf]);
    for (auto& l : tmp) nb.insert(nb.end(), l.begin(), l.end());
  }

  const Bvh bvh(verts, faces);
  std::vector<TransferHit> hits(np);
  const double reach = 2.0 * bandwidth;

#pragma omp parallel
  {
    // Per-thread distance table stamped by query, so lookups need no clearing.
    std::vector<int> stamp(nf, -1);
    std::vector<double> dist(nf, 0.0);
    std::vector<std::pair<double, int>> cand;
#pragma omp for schedule(dynamic, 64)
    for (int q = 0; q < np; ++q) {
      const Vec3 x = points[q];
      TransferHit& h = hits[q];
      const auto [t0, d02] = bvh.nearest(x);
      h.t0 = t0;
      const Vec3 c0 = closest_point_on_triangle(x, verts[faces[t0][0]], verts[faces[t0][1]], verts[faces[t0][2]], h.b0);
      h.d0 = std::sqrt(d02);
      (void)c0;
      const double r = h.d0 + reach;
      cand.clear();
      bvh.within(x, r * r, [&](int t) {
        double bc[3];
        const Vec3 c = closest_point_on_triangle(x, verts[faces[t][0]], verts[faces[t][1]], verts[faces[t][2]], bc);
        const double d = norm(c - x);
        stamp[t] = q;
        dist[t] = d;
        if (d <= r) cand.emplace_back(d, t);
      });
      std::sort(cand.begin(), cand.end());
      auto touches_t0 = [&](int t) {
        for (int s = nb_off[t0]; s < nb_off[t0 + 1]; ++s)
          if (nb[s] == t) return true;
        return false;
      };
      for (const auto& [d, t] : cand) {
        if (touches_t0(t)) continue;
        bool local_min = true;
        // A neighbour outside the gathered set is farther than r >= d, so never closer.
        for (int s = nb_off[t]; s < nb_off[t + 1] && local_min; ++s) {
          const int u = nb[s];
          if (u != t && stamp[u] == q && dist[u] < d) local_min = false;
        }
        if (!local_min) continue;
        h.t1 = t;
        h.d1 = d;
        closest_point_on_triangle(x, verts[faces[t][0]], verts[faces[t][1]], verts[faces[t][2]], h.b1);
        break;
      }
    }
  }
  return hits;
}

}  // namespace seamfit::opt
