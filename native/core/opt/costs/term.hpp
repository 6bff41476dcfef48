// What a fitting cost term is, for the cost sets that run it (opt/cost_set.cpp on the CPU,
// opt/costs_gpu.cu on the GPU) and the registry that lists it (opt/cost_terms.hpp).
//
// A term is a sum over elements (the garment's vertices, edges or interior hinges) of an
// element energy with constant per-element data. Its header defines, beside the energy,
// a struct with
//   kOn       the elements it sums over (Elements below);
//   kWidth    how many constants each element carries (doubles);
//   kInput    nullptr when base() computes them from the base garment and pattern at
//             construction; otherwise what the caller must supply through
//             CostSet::set_inputs (named in the error when it has not);
//   kField    whether element() samples the target body's SDF (CostSet::set_target_sdf);
//   kPattern  whether it depends on the pattern p (and writes gp);
//   base(b, v, c)  the constants c of the element with vertices v (host only);
//   element(in, v, c, k, gx, gp)  the element's value at strength k, its gradient
//             with respect to x at each of its vertices into gx[0..arity) and, with
//             kPattern, with respect to p into gp[0..arity) (host and device).
// The cost sets add up each vertex's gradient term by term, in the registry's order: a term
// over the vertices adds its own straight in, another its elements' slots in slot order
// (opt/costs/gather.hpp). Results do not depend on the thread count, and the CPU and GPU
// add the same values in the same order.
#pragma once
#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

// The elements a term sums over, and how many vertices each has.
enum Elements { kVertices = 0, kEdges = 1, kHinges = 2, kNumElementKinds = 3 };
constexpr int kElementArity[kNumElementKinds] = {1, 2, 4};

// What an element reads besides its constants: the current garment x (n, 3) and pattern
// p (n, 2), in metres, and the target body's SDF (valid for a term with kField).
struct CostInputs {
  const Vec3* x = nullptr;
  const Vec2* p = nullptr;
  SdfGridView sdf;
};

// What base() reads: the base pattern pbar (n, 2) and base garment xbar (n, 3).
struct BaseGarment {
  const Vec2* pbar = nullptr;
  const Vec3* xbar = nullptr;
};

}  // namespace seamfit::opt
