#pragma once

// The point of a segment nearest a point. Degenerate answers: a segment whose ends are
// equal is its first end (parameter 0); non-finite input gives non-finite answers.

#include <algorithm>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// The parameter t in [0, 1] of the point a + t (b - a) nearest p.
inline double ClosestParameterOnSegment(const Vector3& p, const Vector3& a, const Vector3& b) {
  const Vector3 ab = b - a;
  const double length_squared = ab.squaredNorm();
  if (length_squared == 0) return 0;
  return std::clamp((p - a).dot(ab) / length_squared, 0.0, 1.0);
}

// The distance from p to the segment a -> b.
inline double CalcPointSegmentDistance(const Vector3& p, const Vector3& a, const Vector3& b) {
  return (p - (a + ClosestParameterOnSegment(p, a, b) * (b - a))).norm();
}

}  // namespace hapticd::geometry
