// Bounding volume hierarchy over TriPre triangles for exact nearest-triangle queries.
//
// Built on the host (median split along the longest axis of the centroids, at most
// kBvhLeaf triangles a leaf) into a flat node array in depth-first order, so the
// left child of an inner node is the next node and the tree can be copied to a GPU
// as it is. The query `bvh_nearest` is host-device: the CPU seeds the border of a
// cut grid with it, the GPU computes every node of a field with it.
#pragma once
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "body/tri_distance.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"

namespace seamfit::body {

constexpr int kBvhLeaf = 4;
// Traversal stack entries. The depth-first traversal holds at most depth + 1 nodes,
// and a median split of fewer than 2^31 triangles is at most 30 levels deep.
constexpr int kBvhStack = 64;

// Box of the node's triangles (their float vertices, so the float box is exact).
// Leaf (count > 0): triangles order[index .. index + count). Inner node (count == 0):
// children id + 1 and index.
struct BvhNode {
  float lo[3], hi[3];
  int32_t index;
  int32_t count;
};

struct TriBvh {
  std::vector<BvhNode> nodes;
  std::vector<int32_t> order;  // leaf slots -> triangle indices
  int depth = 0;               // levels below the root
};

namespace detail {

struct BvhBuilder {
  const std::vector<TriPre>& tris;
  std::vector<Vec3> cen;
  TriBvh& out;

  int32_t build(int64_t s, int64_t e, int level) {
    const int32_t id = int32_t(out.nodes.size());
    out.nodes.push_back(BvhNode{});
    out.depth = std::max(out.depth, level);
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    double clo[3] = {1e300, 1e300, 1e300}, chi[3] = {-1e300, -1e300, -1e300};
    for (int64_t q = s; q < e; ++q) {
      const TriPre& t = tris[out.order[q]];
      for (const float* v : {t.a, t.b, t.c})
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], double(v[a]));
          hi[a] = std::max(hi[a], double(v[a]));
        }
      const Vec3 m = cen[out.order[q]];
      const double c[3] = {m.x, m.y, m.z};
      for (int a = 0; a < 3; ++a) { clo[a] = std::min(clo[a], c[a]); chi[a] = std::max(chi[a], c[a]); }
    }
    BvhNode nd;
    for (int a = 0; a < 3; ++a) { nd.lo[a] = float(lo[a]); nd.hi[a] = float(hi[a]); }
    if (e - s <= kBvhLeaf) {
      nd.index = int32_t(s);
      nd.count = int32_t(e - s);
      out.nodes[id] = nd;
      return id;
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a) if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
    const int64_t mid = (s + e) / 2;
    std::nth_element(out.order.begin() + s, out.order.begin() + mid, out.order.begin() + e, [&](int32_t x, int32_t y) {
      const Vec3 a = cen[x], b = cen[y];
      return axis == 0 ? a.x < b.x : axis == 1 ? a.y < b.y : a.z < b.z;
    });
    build(s, mid, level + 1);  // left child: id + 1
    const int32_t r = build(mid, e, level + 1);
    nd.index = r;
    nd.count = 0;
    out.nodes[id] = nd;
    return id;
  }
};

}  // namespace detail

inline TriBvh build_tri_bvh(const std::vector<TriPre>& tris) {
  TriBvh bvh;
  if (tris.empty()) throw std::invalid_argument("a BVH needs at least one triangle");
  bvh.order.resize(tris.size());
  std::iota(bvh.order.begin(), bvh.order.end(), 0);
  detail::BvhBuilder b{tris, std::vector<Vec3>(tris.size()), bvh};
  for (size_t t = 0; t < tris.size(); ++t) b.cen[t] = tri_vec(tris[t].centre);
  bvh.nodes.reserve(2 * tris.size() / kBvhLeaf + 2);
  b.build(0, int64_t(tris.size()), 0);
  if (bvh.depth + 1 > kBvhStack) throw std::runtime_error("triangle BVH too deep for its traversal stack");
  return bvh;
}

// Squared distance from p to the node's box (0 inside).
SF_HD double bvh_box_d2(const BvhNode& nd, Vec3 p) {
  const double c[3] = {p.x, p.y, p.z};
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    // max(lo - c, 0, c - hi): at most one of the two differences is positive.
    const double below = double(nd.lo[a]) - c[a], above = c[a] - double(nd.hi[a]);
    const double e = below > 0 ? below : (above > 0 ? above : 0.0);
    d2 += e * e;
  }
  return d2;
}

// Nearest triangle to p. best_d2 and best_t carry an initial candidate (or a huge
// value and -1); they change only for a strictly nearer triangle. order maps leaf
// slots to triangle indices; nullptr when tris are stored in leaf order already
// (best_t is then a leaf slot).
SF_HD void bvh_nearest(const BvhNode* nodes, const int32_t* order, const TriPre* tris, Vec3 p, double& best_d2,
                       int32_t& best_t) {
  int32_t stack[kBvhStack];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const int32_t id = stack[--sp];
    const BvhNode& nd = nodes[id];
    if (bvh_box_d2(nd, p) >= best_d2) continue;
    if (nd.count > 0) {
      for (int32_t q = nd.index; q < nd.index + nd.count; ++q) {
        const int32_t t = order ? order[q] : q;
        const double d2 = tri_dist2(tris[t], p);
        if (d2 < best_d2) { best_d2 = d2; best_t = t; }
      }
      continue;
    }
    const int32_t l = id + 1, r = nd.index;
    const double dl = bvh_box_d2(nodes[l], p), dr = bvh_box_d2(nodes[r], p);
    // Push the farther child first so the nearer one is searched first.
    if (dl < dr) { stack[sp++] = r; stack[sp++] = l; }
    else { stack[sp++] = l; stack[sp++] = r; }
  }
}

// Unsigned distances float(sqrt(d2)) to the nearest triangle of the grid nodes
// (i, j, k), i0 <= i < i1, node (i, j, k) at o + h (i, j, k), into out[i - i0]; tris
// in leaf order. Each query starts from the distance to the triangle nearest to
// the node before, one cell away, which prunes most of the tree at once.
SF_HD void bvh_distance_run(const BvhNode* nodes, const TriPre* tris, const double o[3], double h, int64_t i0,
                            int64_t i1, int64_t j, int64_t k, float* out) {
  const double y = o[1] + h * double(j), z = o[2] + h * double(k);
  int32_t prev = -1;
  for (int64_t i = i0; i < i1; ++i) {
    const Vec3 p = make_vec3(o[0] + h * double(i), y, z);
    double best = 1e300;
    int32_t bt = -1;
    if (prev >= 0) {
      best = tri_dist2(tris[prev], p);
      bt = prev;
    }
    bvh_nearest(nodes, nullptr, tris, p, best, bt);
    out[i - i0] = float(sqrt(best));
    prev = bt;
  }
}

}  // namespace seamfit::body
