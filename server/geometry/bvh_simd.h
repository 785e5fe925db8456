#pragma once

// Internal to the BVH queries (mesh_queries.cc, sphere_sweep.cc): the pieces of a
// front-to-back traversal that test a node's children together. The children are tested
// four at a time, two per vector (GCC/Clang vector extensions: SSE2 or NEON registers
// of two doubles), or in float, four per vector (segments: mesh_queries.cc).

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

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
using Mask4 = int32_t __attribute__((vector_size(16)));
static_assert(kBvhWidth % 4 == 0);

inline Double2 Splat(double x) { return Double2{x, x}; }
inline Float4 SplatFloat(float x) { return Float4{x, x, x, x}; }

inline Float4 Sqrt(Float4 x) {
#if defined(__SSE__)
  return reinterpret_cast<Float4>(_mm_sqrt_ps(reinterpret_cast<__m128>(x)));
#else
  return Float4{std::sqrt(x[0]), std::sqrt(x[1]), std::sqrt(x[2]), std::sqrt(x[3])};
#endif
}

// Four neighbouring floats (a bound of four children), as they are.
inline Float4 LoadFloat4(const float* bounds) {
  Float4 f;
  std::memcpy(&f, bounds, sizeof(f));
  return f;
}

// One bound of four neighbouring children, widened to double (exact).
inline void Load(const float* bounds, Double2& low, Double2& high) {
  const Float4 f = LoadFloat4(bounds);
  low = __builtin_convertvector(Float2(__builtin_shufflevector(f, f, 0, 1)), Double2);
  high = __builtin_convertvector(Float2(__builtin_shufflevector(f, f, 2, 3)), Double2);
}

// Starts loading a node or its discs (all of their cache lines) before they are needed.
template <typename NodePart>
inline void Prefetch(const NodePart& node) {
  const char* bytes = reinterpret_cast<const char*>(&node);
  for (size_t offset = 0; offset < sizeof(NodePart); offset += 64) {
    __builtin_prefetch(bytes + offset);
  }
}

// Squared distance from the box [q_lo, q_hi] to each child box of `node` (0 where they
// overlap; infinite for an empty slot): a lower bound of the distance from anything in
// the box, as from a segment in its own box.
inline void ChildDistancesSquared(const BvhNode& node, const Double2 q_lo[3], const Double2 q_hi[3],
                                  double d2[kBvhWidth]) {
  for (int c = 0; c < kBvhWidth; c += 4) {
    Double2 sum[2] = {Splat(0), Splat(0)};
    for (int a = 0; a < 3; ++a) {
      Double2 lo[2], hi[2];
      Load(node.lo[a] + c, lo[0], lo[1]);
      Load(node.hi[a] + c, hi[0], hi[1]);
      for (int h = 0; h < 2; ++h) {
        const Double2 below = lo[h] - q_hi[a];
        const Double2 above = q_lo[a] - hi[h];
        Double2 gap = below > above ? below : above;
        gap = gap > 0 ? gap : Splat(0);
        sum[h] += gap * gap;
      }
    }
    for (int h = 0; h < 2; ++h) {
      d2[c + 2 * h] = sum[h][0];
      d2[c + 2 * h + 1] = sum[h][1];
    }
  }
}

// A box and a distance, for ChildrenWithin in float (the gather of triangles near a
// segment: sphere_sweep.cc). The box is rounded outwards to float, so its distance from
// a child box is never more than the exact box's; each gap (one subtraction of floats)
// and its square are rounded, and two sums, each within 2^-24, so the float squared
// distance is at most (1 + 2^-24)^5 < 1 + 2^-21 times the exact one, and the limit is
// keep^2 rounded up (RoundUpToFloat; at the largest float the factor makes it
// infinite), times (1 + 2^-20), plus a floor for underflow. Float carries
// this only for coordinates within +-1e30; `usable` says so, and the caller takes
// ChildDistancesSquared where it is false.
struct FloatBoxWithin {
  static constexpr double kMaxCoordinate = 1e30;
  Float4 lo[3];
  Float4 hi[3];
  Float4 limit_squared;
  bool usable = true;

  FloatBoxWithin(const Aabb& box, double keep) {
    for (int a = 0; a < 3; ++a) {
      if (!(std::abs(box.min[a]) <= kMaxCoordinate && std::abs(box.max[a]) <= kMaxCoordinate)) {
        usable = false;
        return;
      }
      lo[a] = SplatFloat(RoundDownToFloat(box.min[a]));
      hi[a] = SplatFloat(RoundUpToFloat(box.max[a]));
    }
    const float limit = RoundUpToFloat(keep * keep);
    limit_squared = SplatFloat(limit * (1 + 1.0f / (1 << 20)) + 1e-30f);
  }

  // Bit c set where child c of node may lie within keep of the box (an empty slot may
  // be set too: it holds nothing).
  int ChildrenWithin(const BvhNode& node) const {
    static_assert(kBvhWidth == 4, "one vector of four children per node");
    Float4 sum = SplatFloat(0);
    for (int a = 0; a < 3; ++a) {
      const Float4 below = LoadFloat4(node.lo[a]) - hi[a];
      const Float4 above = lo[a] - LoadFloat4(node.hi[a]);
      Float4 gap = below > above ? below : above;
      gap = gap > 0 ? gap : SplatFloat(0);
      sum += gap * gap;
    }
    const Mask4 within = sum <= limit_squared;
    return (within[0] & 1) | (within[1] & 2) | (within[2] & 4) | (within[3] & 8);
  }
};

// A segment a -> a + d and a distance, for ChildrenWithin a node's discs (BvhDiscs), in
// float: the second test of the gather and of the sphere sweep, after the boxes. Over the segment, the least height
// over a disc's plane beyond its thickness and the least distance within the plane
// beyond its radius bound the distance to anything in the disc below (the bound of
// LowerDistanceExceeds in sphere_sweep.cc, for a triangle: a disc of no thickness).
// The offsets from the centres are taken in double, so float rounds each quantity by a
// relative few 1e-7 of the largest magnitude in play (offset, motion, distance, radius,
// thickness; the normal is unit to 1e-7 too): a child is passed over only where the bound
// squared exceeds the distance squared by 1e-5 of the sum of those magnitudes squared,
// far above that rounding. Anything not finite on the way (a disc of infinite radius,
// an overflow) keeps the child, and so does every child for a distance or motion whose
// square float cannot hold comfortably (1e18 or more).
struct FloatDiscsWithin {
  static constexpr float kSlack = 1e-5f;
  static constexpr double kMaxLength = 1e18;
  Double2 a[3];
  Float4 d[3];
  float keep_squared;
  float motion_squared;
  bool keeps_all;

  FloatDiscsWithin(const Vector3& start, const Vector3& motion, double keep) {
    for (int axis = 0; axis < 3; ++axis) {
      a[axis] = Splat(start[axis]);
      d[axis] = SplatFloat(static_cast<float>(motion[axis]));
    }
    keep_squared = RoundUpToFloat(keep * keep);
    motion_squared = static_cast<float>(motion.squaredNorm());
    keeps_all = !(keep < kMaxLength && motion.norm() < kMaxLength);
  }

  // Bit c set where child c may hold something within keep of the segment.
  int ChildrenWithin(const BvhDiscs& discs) const {
    static_assert(kBvhWidth == 4, "one vector of four children per node");
    if (keeps_all) return (1 << kBvhWidth) - 1;
    Float4 o[3], n[3];
    for (int axis = 0; axis < 3; ++axis) {
      Double2 low, high;
      Load(discs.centre[axis], low, high);
      low = a[axis] - low;
      high = a[axis] - high;
      o[axis] = __builtin_shufflevector(__builtin_convertvector(low, Float2), __builtin_convertvector(high, Float2),
                                        0, 1, 2, 3);
      n[axis] = LoadFloat4(discs.normal[axis]);
    }
    const Float4 radius = LoadFloat4(discs.radius);
    const Float4 thickness = LoadFloat4(discs.thickness);
    const Float4 zero = SplatFloat(0);
    // heights over the plane at both ends: the least, 0 where the segment crosses it
    const Float4 height_a = n[0] * o[0] + n[1] * o[1] + n[2] * o[2];
    const Float4 climb = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    const Float4 height_b = height_a + climb;
    const Float4 abs_a = height_a < 0 ? -height_a : height_a;
    const Float4 abs_b = height_b < 0 ? -height_b : height_b;
    const Float4 least = height_a * height_b > 0 ? (abs_a < abs_b ? abs_a : abs_b) : zero;
    Float4 above = least - thickness;
    above = above > 0 ? above : zero;
    // within the plane: the point of the segment's shadow nearest the centre
    Float4 lateral[3], drift[3];
    for (int axis = 0; axis < 3; ++axis) {
      lateral[axis] = o[axis] - height_a * n[axis];
      drift[axis] = d[axis] - climb * n[axis];
    }
    const Float4 drift_squared = drift[0] * drift[0] + drift[1] * drift[1] + drift[2] * drift[2];
    const Float4 toward = -(lateral[0] * drift[0] + lateral[1] * drift[1] + lateral[2] * drift[2]);
    Float4 t = drift_squared > 0 ? toward / drift_squared : zero;
    t = t > 0 ? t : zero;
    t = t < 1 ? t : SplatFloat(1);
    Float4 nearest_squared = zero;
    for (int axis = 0; axis < 3; ++axis) {
      const Float4 p = lateral[axis] + t * drift[axis];
      nearest_squared += p * p;
    }
    Float4 beside = Sqrt(nearest_squared) - radius;
    beside = beside > 0 ? beside : zero;
    const Float4 bound_squared = above * above + beside * beside;
    const Float4 magnitudes = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + motion_squared + keep_squared +
                              radius * radius + thickness * thickness;
    const Mask4 far = bound_squared > keep_squared + kSlack * magnitudes;
    return ~((far[0] & 1) | (far[1] & 2) | (far[2] & 4) | (far[3] & 8)) & 0xf;
  }
};

// Squared distance from p to each child box of `node` (0 inside; infinite for an
// empty slot): the box form above, the box shrunk to p.
inline void ChildDistancesSquared(const BvhNode& node, const Double2 p[3], double d2[kBvhWidth]) {
  ChildDistancesSquared(node, p, p, d2);
}

}  // namespace hapticd::geometry::bvh_simd
