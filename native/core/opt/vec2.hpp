// Minimal 2-vector math for pattern-space positions, usable on host and device
// (the companion of common/vec3.hpp for the optimizer's pattern variables).
#pragma once
#include <cmath>
#include "common/hd.hpp"

namespace seamfit {

struct Vec2 {
  double x, y;
};

SF_HD Vec2 make_vec2(double x, double y) { return Vec2{x, y}; }
SF_HD Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
SF_HD Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
SF_HD Vec2 operator-(Vec2 a) { return {-a.x, -a.y}; }
SF_HD Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
SF_HD Vec2 operator*(Vec2 a, double s) { return {s * a.x, s * a.y}; }
SF_HD Vec2& operator+=(Vec2& a, Vec2 b) { a.x += b.x; a.y += b.y; return a; }
SF_HD double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
SF_HD double norm2(Vec2 a) { return dot(a, a); }
SF_HD double norm(Vec2 a) { return sqrt(dot(a, a)); }
// Complex product: treats a 2-vector as a + ib, i.e. rotation-and-scale of b by a.
SF_HD Vec2 cmul(Vec2 a, Vec2 b) { return {a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x}; }
// Complex quotient a / b (b != 0).
SF_HD Vec2 cdiv(Vec2 a, Vec2 b) {
  const double d = b.x * b.x + b.y * b.y;
  return {(a.x * b.x + a.y * b.y) / d, (a.y * b.x - a.x * b.y) / d};
}
// Transpose of the complex product as a linear map of b: (cmul(a, .))^T g = conj(a) g.
SF_HD Vec2 cmul_t(Vec2 a, Vec2 g) { return {a.x * g.x + a.y * g.y, -a.y * g.x + a.x * g.y}; }

}  // namespace seamfit
