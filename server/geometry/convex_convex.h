#pragma once

// Convex-convex contact between two point sets (each shape the convex hull of its
// points): intersection, signed distance, normal and witness points, as the
// conformance op convex_convex defines them.
//
// Theory of operation:
//   hulls (Quickhull, exact) -> GJK distance
//     gap clearly > 0          -> separated: GJK's distance, normal and witnesses
//     else penetration depth (exact candidate axes, penetration.h)
//       depth clearly > 0      -> overlapping: -depth and its axis
//       else (|distance| within rounding of 0) -> the exact intersection test decides,
//         so touching hulls (sharing only boundary points) report intersect, and a
//         depth within rounding of 0 (16 ulps of the coordinates) reads as 0.
// "Clearly" means beyond 1e-10 of the coordinates' magnitude: far beyond rounding.

#include <vector>

#include "server/geometry/convex_hull.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct ConvexConvexResult {
  // True when the closed hulls share a point (touching counts). Decided exactly.
  bool intersect = false;
  // Signed: > 0 the gap, < 0 minus the penetration depth (the length of the shortest
  // translation that separates them), 0 when they touch.
  double distance = 0;
  // Unit, from a towards b: point_b - point_a = distance * normal. Translating b by
  // -distance * normal leaves the hulls touching.
  Vector3 normal = Vector3::UnitX();
  // Witness points on the hulls: the nearest points when separated; when overlapping,
  // the point of a deepest inside b and its partner on b's boundary.
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
};

// Contact between the hulls of points_a and points_b (one frame, metres).
// Preconditions: both non-empty, finite (ValidatePointSet). Degenerate sets (one
// point, collinear, coplanar) are fine. Non-finite input gives intersect = false and
// a NaN distance, never a crash. Allocates (the hulls).
ConvexConvexResult CollideConvex(const std::vector<Vector3>& points_a, const std::vector<Vector3>& points_b);

// The same on prebuilt hulls (dimension >= 0).
ConvexConvexResult CollideHulls(const ConvexHull& a, const ConvexHull& b);

// Exact: true when the closed hulls share at least one point. Every finite input
// within the predicates' range gets the right answer. Cost O(E_a F_b + E_b F_a) in
// the worst case (CollideHulls only calls it near contact, on the features near the
// contact plane). Precondition: non-empty hulls.
bool HullsIntersect(const ConvexHull& a, const ConvexHull& b);

}  // namespace hapticd::geometry
