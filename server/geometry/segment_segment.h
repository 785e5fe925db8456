#pragma once

// Closest points between two segments (Ericson, "Real-Time Collision Detection",
// 5.1.9), made robust for parallel, nearly parallel and zero-length segments.

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SegmentSegmentClosest {
  double s = 0;  // point_a = p0 + s (p1 - p0), s in [0, 1]
  double t = 0;  // point_b = q0 + t (q1 - q0), t in [0, 1]
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
  double distance_squared = 0;
};

// The closest pair of points of segments p0-p1 and q0-q1. Where the pair is not unique
// (parallel overlapping segments) one of the closest pairs is returned. A zero-length
// segment acts as its point (its parameter is 0). Non-finite input gives NaN fields,
// never a crash.
SegmentSegmentClosest FindClosestPointsBetweenSegments(const Vector3& p0, const Vector3& p1,
                                                       const Vector3& q0, const Vector3& q1);

}  // namespace hapticd::geometry
