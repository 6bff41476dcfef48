// Minimal 3-vector math usable on host and device (Eigen types are not used in
// kernels, so the shared energy code stays plain and register friendly).
#pragma once
#include <cmath>
#include "common/hd.hpp"

namespace seamfit {

struct Vec3 {
  double x, y, z;
};

SF_HD Vec3 make_vec3(double x, double y, double z) { return Vec3{x, y, z}; }
SF_HD Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
SF_HD Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
SF_HD Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
SF_HD Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
SF_HD Vec3 operator*(Vec3 a, double s) { return {s * a.x, s * a.y, s * a.z}; }
SF_HD Vec3& operator+=(Vec3& a, Vec3 b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
SF_HD Vec3& operator-=(Vec3& a, Vec3 b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
SF_HD double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
SF_HD Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
SF_HD double norm2(Vec3 a) { return dot(a, a); }
SF_HD double norm(Vec3 a) { return sqrt(dot(a, a)); }

}  // namespace seamfit
