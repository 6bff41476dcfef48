// A C2 reading of the SDF grid for the barrier: the uniform cubic B-spline
// whose control values are the grid values (no prefilter).
//
// Why not the trilinear interpolant: its gradient jumps across every cell face.
// A vertex pressed onto the body with normal force F then meets a tangential
// "step" of about F * h / R (h the spacing, R the local radius of curvature) at
// each face, and gradient descent jams there like static friction (observed on
// tight necklines: 0.1 N traps with a 2.5 mm grid, a hundred times a vertex's
// weight). The B-spline is C2, so forces and stiffness vary smoothly. It
// smooths the field by about h^2/6 * laplacian(phi) (0.04 mm on a 5 cm radius
// neck with h = 2.5 mm), far below the barrier gap.
//
// Outside the grid the field continues like sdf_sample: the value at the
// clamped point plus the distance to the grid box.
#pragma once
#include <cstdint>
#include "body/sdf_grid.hpp"
#include "common/hd.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"

namespace seamfit::sim {

struct SdfSample2 {
  double phi;
  Vec3 grad;
  Sym3 hess;
};

// Cubic B-spline weights (and first and second derivatives) for t in [0, 1]
// on the nodes i-1, i, i+1, i+2.
SF_HD void bspline3(double t, double w[4], double d[4], double dd[4]) {
  const double s = 1.0 - t, t2 = t * t, t3 = t2 * t;
  w[0] = s * s * s / 6.0;
  w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
  w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
  w[3] = t3 / 6.0;
  d[0] = -0.5 * s * s;
  d[1] = 0.5 * (3.0 * t2 - 4.0 * t);
  d[2] = 0.5 * (-3.0 * t2 + 2.0 * t + 1.0);
  d[3] = 0.5 * t2;
  dd[0] = s;
  dd[1] = 3.0 * t - 2.0;
  dd[2] = -3.0 * t + 1.0;
  dd[3] = t;
}

template <bool kHessian>
SF_HD SdfSample2 sdf_sample_smooth(const SdfGridView& g, Vec3 p) {
  const double h = g.spacing;
  const SdfCell cell = sdf_cell(g, p);
  const int n[3] = {g.nx, g.ny, g.nz};
  const double* outside = cell.outside;
  const bool* clamped = cell.clamped;
  int idx[3][4];
  double w[3][4], d[3][4], dd[3][4];
  for (int a = 0; a < 3; ++a) {
    const int b = cell.base[a];
    bspline3(cell.t[a], w[a], d[a], dd[a]);
    for (int k = 0; k < 4; ++k) {
      int i = b - 1 + k;
      idx[a][k] = i < 0 ? 0 : (i > n[a] - 1 ? n[a] - 1 : i);  // replicate the border
    }
    if (clamped[a])
      for (int k = 0; k < 4; ++k) { d[a][k] = 0; dd[a][k] = 0; }
  }
  // Separable accumulation: contract x, then y, then z.
  double v = 0, gx = 0, gy = 0, gz = 0, hxx = 0, hyy = 0, hzz = 0, hxy = 0, hxz = 0, hyz = 0;
  for (int kz = 0; kz < 4; ++kz) {
    double sv = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int ky = 0; ky < 4; ++ky) {
      const float* row = g.values + int64_t(g.nx) * (idx[1][ky] + int64_t(g.ny) * idx[2][kz]);
      double r0 = 0, r1 = 0, r2 = 0;
      for (int kx = 0; kx < 4; ++kx) {
        const double c = double(row[idx[0][kx]]);
        r0 += w[0][kx] * c;
        r1 += d[0][kx] * c;
        if (kHessian) r2 += dd[0][kx] * c;
      }
      sv += w[1][ky] * r0;
      sx += w[1][ky] * r1;
      sy += d[1][ky] * r0;
      if (kHessian) {
        sxx += w[1][ky] * r2;
        syy += dd[1][ky] * r0;
        sxy += d[1][ky] * r1;
      }
    }
    v += w[2][kz] * sv;
    gx += w[2][kz] * sx;
    gy += w[2][kz] * sy;
    gz += d[2][kz] * sv;
    if (kHessian) {
      hxx += w[2][kz] * sxx;
      hyy += w[2][kz] * syy;
      hzz += dd[2][kz] * sv;
      hxy += w[2][kz] * sxy;
      hxz += d[2][kz] * sx;
      hyz += d[2][kz] * sy;
    }
  }
  SdfSample2 s;
  s.phi = v;
  s.grad = make_vec3(gx / h, gy / h, gz / h);
  const double ih2 = 1.0 / (h * h);
  s.hess = {hxx * ih2, hyy * ih2, hzz * ih2, hxy * ih2, hxz * ih2, hyz * ih2};
  const double od2 = outside[0] * outside[0] + outside[1] * outside[1] + outside[2] * outside[2];
  if (od2 > 0) {
    const double od = sqrt(od2);
    s.phi += od;
    if (clamped[0]) s.grad.x = outside[0] / od;
    if (clamped[1]) s.grad.y = outside[1] / od;
    if (clamped[2]) s.grad.z = outside[2] / od;
    if (kHessian) {
      double m[3][3];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          m[a][b] = (clamped[a] && clamped[b]) ? ((a == b ? 1.0 : 0.0) - outside[a] * outside[b] / od2) / od : 0.0;
      s.hess.xx += m[0][0]; s.hess.yy += m[1][1]; s.hess.zz += m[2][2];
      s.hess.xy += m[0][1]; s.hess.xz += m[0][2]; s.hess.yz += m[1][2];
    }
  }
  return s;
}

}  // namespace seamfit::sim
