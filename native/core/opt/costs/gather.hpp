// Per-vertex sum of element gradient slots, in slot order: the cost sets' gather on
// the CPU (opt/cost_set.cpp) and the GPU (opt/costs_gpu.cu), no atomics.
#pragma once
#include "common/hd.hpp"

namespace seamfit {

// acc += slot_vals[slots[s]] for s in [offsets[v], offsets[v + 1]).
template <class T>
SF_HD void gather_add(int v, const int* offsets, const int* slots, const T* slot_vals, T& acc) {
  for (int s = offsets[v]; s < offsets[v + 1]; ++s) acc += slot_vals[slots[s]];
}

}  // namespace seamfit
