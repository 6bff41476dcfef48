// Body-surface queries for the deformation transfer of Eq. 15.
//
// For each garment point x on the base body this finds
//   t0: the closest body triangle (distance d0, closest point with barycentrics b0);
//   t1: the second local minimum: the closest triangle that (a) is a local minimum of
//       the point-to-triangle distance over the mesh, i.e. no triangle sharing a vertex
//       with it is strictly closer, and (b) shares no vertex with t0. Only triangles
//       within d0 + 2B matter (beyond that Eq. 15 gives them weight 0), so the search is
//       limited to them; t1 = -1 when there is none.
// Condition (a) keeps t1 off the slope of t0's own basin (on a flat or convex patch the
// ring of triangles around t0 is never a local minimum), so t1 is a genuinely separate
// sheet: the other leg at the crotch, the torso beside an arm. Condition (b) removes
// the triangles tied with t0 at a shared edge or vertex.
#pragma once
#include <array>
#include <vector>

#include "common/vec3.hpp"

namespace seamfit::opt {

struct TransferHit {
  int t0 = -1, t1 = -1;
  double d0 = 0, d1 = 0;
  double b0[3] = {0, 0, 0}, b1[3] = {0, 0, 0};
};

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5);
// bary receives its barycentric coordinates.
Vec3 closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c, double bary[3]);

// verts (nv, 3), faces (nf, 3), points (np, 3); bandwidth B > 0 in metres.
std::vector<TransferHit> transfer_query(const std::vector<Vec3>& verts, const std::vector<std::array<int, 3>>& faces,
                                        const std::vector<Vec3>& points, double bandwidth);

}  // namespace seamfit::opt
