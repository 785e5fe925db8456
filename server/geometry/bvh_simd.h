#pragma once

// Internal to the BVH queries (mesh_queries.cc, sphere_sweep.cc): the pieces of a
// front-to-back traversal that test a node's children together. The children are tested
// four at a time, two per vector (GCC/Clang vector extensions: SSE2 or NEON registers
// of two doubles).

#include <cstdint>
#include <cstring>

#include "server/geometry/bvh.h"

namespace hapticd::geometry::bvh_simd {

// Relative slack on the far end of a slab interval. Each slab distance
// (b - o) * (1 / d), with d = q - p rounded, is within a few ulps of the true one and
// has the exact sign, so widening the far end by a few ulps keeps every box the exact
// segment touches (after Ize 2013, "Robust BVH ray traversal").
constexpr double kSlabSlack = 1 + 1e-14;

using Double2 = double __attribute__((vector_size(16)));
using Float2 = float __attribute__((vector_size(8)));
using Float4 = float __attribute__((vector_size(16)));
using Mask2 = int64_t __attribute__((vector_size(16)));
static_assert(kBvhWidth % 4 == 0);

inline Double2 Splat(double x) { return Double2{x, x}; }

// One bound of four neighbouring children, widened to double (exact).
inline void Load(const float* bounds, Double2& low, Double2& high) {
  Float4 f;
  std::memcpy(&f, bounds, sizeof(f));
  low = __builtin_convertvector(Float2(__builtin_shufflevector(f, f, 0, 1)), Double2);
  high = __builtin_convertvector(Float2(__builtin_shufflevector(f, f, 2, 3)), Double2);
}

// Starts loading a node (all of its cache lines) before it is needed.
inline void Prefetch(const BvhNode& node) {
  const char* bytes = reinterpret_cast<const char*>(&node);
  for (size_t offset = 0; offset < sizeof(BvhNode); offset += 64) {
    __builtin_prefetch(bytes + offset);
  }
}

}  // namespace hapticd::geometry::bvh_simd
