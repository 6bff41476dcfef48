// Exact point-triangle distance with per-triangle precomputation.
//
// The SDF build evaluates tens of millions of point-triangle distances at random
// triangles, so a triangle is stored in one 64-byte cache line: vertices, unit
// normal and bounding sphere as floats (in a frame centred on the grid, where a
// float is good to ~0.1 micrometre for a body-sized mesh); the arithmetic is in
// double. The query walks the Voronoi regions of vertices, edges and face.
// Degenerate triangles (zero area) fall back to their edges, so a sliver never
// divides by zero. The queries are host-device (the GPU field build uses them);
// make_tri runs on the host only.
#pragma once
#include <algorithm>
#include <cmath>

#include "common/hd.hpp"
#include "common/vec3.hpp"

namespace seamfit::body {

// std::min / std::max / std::clamp with their exact semantics (same result, same
// argument on ties), usable in device code.
SF_HD double hd_min(double a, double b) { return b < a ? b : a; }
SF_HD double hd_max(double a, double b) { return a < b ? b : a; }
SF_HD double hd_clamp(double v, double lo, double hi) { return v < lo ? lo : (hi < v ? hi : v); }

struct alignas(64) TriPre {
  float a[3], b[3], c[3];
  float n[3];        // unit normal (zero for degenerate triangles)
  float centre[3];   // centroid, and the radius of the sphere about it holding the triangle
  float radius;
  int degenerate;
};

SF_HD Vec3 tri_vec(const float* v) { return make_vec3(v[0], v[1], v[2]); }

inline TriPre make_tri(Vec3 a, Vec3 b, Vec3 c) {
  TriPre t;
  const Vec3 ab = b - a, ac = c - a;
  const Vec3 cr = cross(ab, ac);
  const double len = norm(cr);
  const double scale = norm2(ab) + norm2(ac) + norm2(c - b);
  // Relative threshold: below it the face-region formula loses all precision.
  t.degenerate = !(len > 1e-12 * scale) || !std::isfinite(len);
  const Vec3 n = t.degenerate ? make_vec3(0, 0, 0) : (1.0 / len) * cr;
  const Vec3 cen = (1.0 / 3.0) * (a + b + c);
  const Vec3 src[5] = {a, b, c, n, cen};
  float* dst[5] = {t.a, t.b, t.c, t.n, t.centre};
  for (int q = 0; q < 5; ++q) {
    dst[q][0] = float(src[q].x);
    dst[q][1] = float(src[q].y);
    dst[q][2] = float(src[q].z);
  }
  // Radius about the float centre of the float vertices, rounded up.
  double r2 = 0;
  for (const float* v : {t.a, t.b, t.c}) r2 = std::max(r2, norm2(tri_vec(v) - tri_vec(t.centre)));
  t.radius = float(std::sqrt(r2) * (1 + 1e-6) + 1e-9);
  return t;
}

SF_HD double seg_dist2(Vec3 p, Vec3 a, Vec3 b) {
  Vec3 ab = b - a, ap = p - a;
  double l2 = norm2(ab);
  double s = l2 > 0 ? hd_clamp(dot(ap, ab) / l2, 0.0, 1.0) : 0.0;
  return norm2(ap - s * ab);
}

// Squared distance from p to triangle t.
SF_HD double tri_dist2(const TriPre& t, Vec3 p) {
  const Vec3 A = tri_vec(t.a), B = tri_vec(t.b), C = tri_vec(t.c);
  if (t.degenerate) return hd_min(seg_dist2(p, A, B), hd_min(seg_dist2(p, B, C), seg_dist2(p, C, A)));
  const Vec3 ab = B - A, ac = C - A;
  const Vec3 ap = p - A;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return norm2(ap);
  const Vec3 bp = p - B;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return norm2(bp);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return norm2(ap - v * ab);
  }
  const Vec3 cp = p - C;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return norm2(cp);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return norm2(ap - w * ac);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return norm2(bp - w * (C - B));
  }
  // Inside the face region: distance to the plane.
  const double s = dot(ap, tri_vec(t.n));
  return s * s;
}

// Lower bound on the distance from p to t (plane and bounding sphere), or 0.
SF_HD double tri_lower_bound(const TriPre& t, Vec3 p) {
  const double pl = fabs(dot(p - tri_vec(t.a), tri_vec(t.n)));
  const double sp = norm(p - tri_vec(t.centre)) - double(t.radius);
  return hd_max(pl, sp);
}

}  // namespace seamfit::body
