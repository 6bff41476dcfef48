#include "opt/topology.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace seamfit::opt {

std::vector<Edge> unique_edges(const std::vector<Tri>& tris) {
  std::vector<Edge> e;
  e.reserve(tris.size() * 3);
  for (const Tri& t : tris)
    for (int a = 0; a < 3; ++a) {
      int u = t[a], v = t[(a + 1) % 3];
      e.push_back({std::min(u, v), std::max(u, v)});
    }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

std::vector<Hinge> interior_hinges(const std::vector<Tri>& tris) {
  // Directed edge (u -> v) in triangle orientation -> opposite vertex.
  std::map<std::pair<int, int>, int> opposite;
  std::map<std::pair<int, int>, int> count;
  for (const Tri& t : tris)
    for (int a = 0; a < 3; ++a) {
      const int u = t[a], v = t[(a + 1) % 3], w = t[(a + 2) % 3];
      if (opposite.count({u, v}))
        throw std::invalid_argument("triangles sharing edge " + std::to_string(u) + "-" + std::to_string(v) +
                                    " are not consistently oriented");
      opposite[{u, v}] = w;
      ++count[{std::min(u, v), std::max(u, v)}];
    }
  std::vector<Hinge> h;
  for (const auto& [uv, w] : opposite) {
    const int u = uv.first, v = uv.second;
    if (u > v) continue;  // each interior edge once, from its (min, max) direction
    auto it = opposite.find({v, u});
    if (it == opposite.end()) continue;  // boundary edge
    if (count[{u, v}] != 2) continue;    // non-manifold: no hinge
    h.push_back({u, v, w, it->second});
  }
  return h;
}

static double cot_at(Vec2 apex, Vec2 a, Vec2 b) {
  const Vec2 u = a - apex, v = b - apex;
  const double c = u.x * v.y - u.y * v.x;
  if (c == 0) throw std::invalid_argument("degenerate triangle in the base pattern");
  return dot(u, v) / std::fabs(c);
}

static double tri_shape(Vec2 a, Vec2 b, Vec2 c) {
  const Vec2 u = b - a, v = c - a;
  const double lmax = std::max(norm2(u), std::max(norm2(v), norm2(c - b)));
  return lmax > 0 ? std::fabs(u.x * v.y - u.y * v.x) / lmax : 0.0;
}

bool hinge_well_shaped(const Hinge& h, const Vec2* rest) {
  return tri_shape(rest[h[0]], rest[h[1]], rest[h[2]]) >= kHingeMinShape &&
         tri_shape(rest[h[1]], rest[h[0]], rest[h[3]]) >= kHingeMinShape;
}

std::array<double, 4> hinge_kernel(const Hinge& h, const Vec2* rest) {
  const Vec2 pi = rest[h[0]], pj = rest[h[1]], pk = rest[h[2]], pl = rest[h[3]];
  const double ci1 = cot_at(pi, pj, pk), cj1 = cot_at(pj, pi, pk);
  const double ci2 = cot_at(pi, pj, pl), cj2 = cot_at(pj, pi, pl);
  const double inv_e = 1.0 / norm(pj - pi);
  return {-(cj1 + cj2) * inv_e, -(ci1 + ci2) * inv_e, (ci1 + cj1) * inv_e, (ci2 + cj2) * inv_e};
}

void Gather::build(const int* elem, int n_elem, int k, int n_vertices) {
  offsets.assign(n_vertices + 1, 0);
  for (int s = 0; s < n_elem * k; ++s) ++offsets[elem[s] + 1];
  for (int v = 0; v < n_vertices; ++v) offsets[v + 1] += offsets[v];
  slots.assign(offsets[n_vertices], 0);
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (int s = 0; s < n_elem * k; ++s) slots[fill[elem[s]]++] = s;
}

}  // namespace seamfit::opt
