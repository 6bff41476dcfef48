// A signed distance field phi sampled on a regular grid (metres, negative inside
// the body). Values are stored as float at grid nodes; queries interpolate
// trilinearly and return the exact gradient of that interpolant, so value and
// gradient are consistent for the barrier energy and its finite-difference tests.
//
// SdfGridView is a non-owning view usable on host and device: the CPU simulator
// points it at host memory, the CUDA backend at device memory.
#pragma once
#include <cstdint>
#include "common/hd.hpp"
#include "common/vec3.hpp"

namespace seamfit {

struct SdfGridView {
  const float* values = nullptr;  // size nx*ny*nz, index i + nx*(j + ny*k)
  int nx = 0, ny = 0, nz = 0;
  double origin[3] = {0, 0, 0};   // world position of node (0,0,0)
  double spacing = 0;             // node spacing h (metres)
};

struct SdfSample {
  double phi;
  Vec3 grad;
};

// The grid cell that holds p, the one lookup every interpolant of the field starts from
// (trilinear here, its Hessian in sim/terms/barrier.hpp, the cubic B-spline in
// sim/terms/sdf_smooth.hpp). Per axis: the cell's first node base (0 <= base <= n - 2),
// p's position t within the cell, and for a p beyond the grid box how far beyond
// (outside, metres) with the axis clamped to the box.
struct SdfCell {
  int base[3];
  double t[3];
  double outside[3];
  bool clamped[3];
};

SF_HD SdfCell sdf_cell(const SdfGridView& g, Vec3 p) {
  const double h = g.spacing;
  double q[3] = {(p.x - g.origin[0]) / h, (p.y - g.origin[1]) / h, (p.z - g.origin[2]) / h};
  const int n[3] = {g.nx, g.ny, g.nz};
  SdfCell c;
  for (int a = 0; a < 3; ++a) {
    const double hi = double(n[a] - 1);
    c.outside[a] = 0;
    c.clamped[a] = false;
    if (q[a] < 0) { c.outside[a] = q[a] * h; q[a] = 0; c.clamped[a] = true; }
    else if (q[a] > hi) { c.outside[a] = (q[a] - hi) * h; q[a] = hi; c.clamped[a] = true; }
    int b = int(floor(q[a]));
    if (b > n[a] - 2) b = n[a] - 2;
    if (b < 0) b = 0;
    c.base[a] = b;
    c.t[a] = q[a] - b;
  }
  return c;
}

// The stored value at node (i, j, k).
SF_HD double sdf_node(const SdfGridView& g, int i, int j, int k) {
  return double(g.values[i + int64_t(g.nx) * (j + int64_t(g.ny) * k)]);
}

// Trilinear value and gradient. Outside the grid the value continues as the
// value at the nearest boundary point plus the distance to the grid box, with a
// gradient pointing away from the box, so a far-away vertex is pulled back in
// with a positive, growing phi and never sees a spurious negative value.
// Grids have at least 2 nodes per axis (the builder guarantees it). A NaN
// point yields a NaN phi, which callers treat as an invalid state.
SF_HD SdfSample sdf_sample(const SdfGridView& g, Vec3 p) {
  const double h = g.spacing;
  if (!(p.x == p.x && p.y == p.y && p.z == p.z)) {
    SdfSample bad;
    bad.phi = p.x + p.y + p.z;  // NaN
    bad.grad = make_vec3(0, 0, 0);
    return bad;
  }
  const SdfCell cell = sdf_cell(g, p);
  const double* t = cell.t;
  const double* outside = cell.outside;
  auto at = [&](int i, int j, int k) -> double {
    return sdf_node(g, cell.base[0] + i, cell.base[1] + j, cell.base[2] + k);
  };
  const double c000 = at(0, 0, 0), c100 = at(1, 0, 0), c010 = at(0, 1, 0), c110 = at(1, 1, 0);
  const double c001 = at(0, 0, 1), c101 = at(1, 0, 1), c011 = at(0, 1, 1), c111 = at(1, 1, 1);
  const double tx = t[0], ty = t[1], tz = t[2];
  const double c00 = c000 + (c100 - c000) * tx, c10 = c010 + (c110 - c010) * tx;
  const double c01 = c001 + (c101 - c001) * tx, c11 = c011 + (c111 - c011) * tx;
  const double c0 = c00 + (c10 - c00) * ty, c1 = c01 + (c11 - c01) * ty;
  SdfSample s;
  s.phi = c0 + (c1 - c0) * tz;
  const double dx = ((c100 - c000) * (1 - ty) + (c110 - c010) * ty) * (1 - tz) +
                    ((c101 - c001) * (1 - ty) + (c111 - c011) * ty) * tz;
  const double dy = (c10 - c00) * (1 - tz) + (c11 - c01) * tz;
  const double dz = c1 - c0;
  s.grad = make_vec3(dx / h, dy / h, dz / h);
  const double od = sqrt(outside[0] * outside[0] + outside[1] * outside[1] + outside[2] * outside[2]);
  if (od > 0) {
    // Outside the box: add the distance to the box; its gradient is the unit
    // direction away from the box (the interpolant's gradient is dropped along
    // clamped axes, which keeps the field continuous).
    s.phi += od;
    double gx = outside[0] != 0 ? outside[0] / od : s.grad.x;
    double gy = outside[1] != 0 ? outside[1] / od : s.grad.y;
    double gz = outside[2] != 0 ? outside[2] / od : s.grad.z;
    s.grad = make_vec3(gx, gy, gz);
  }
  return s;
}

}  // namespace seamfit
