#pragma once

// The point of a triangle closest to a query point (Ericson, "Real-Time Collision
// Detection", 5.1.5), with the feature it lies on: the basis of distance queries,
// sphere contacts and inside/outside tests by pseudo-normals.
//
// Degenerate triangles (zero area) are handled: the answer is then the closest point
// of the segment or point they collapse to, reported as an edge or vertex feature.

#include "server/geometry/types.h"

namespace hapticd::geometry {

// Which part of the triangle the closest point lies in. Edges are named by their
// endpoints: kEdge01 joins v0 and v1.
enum class TriangleFeature { kVertex0, kVertex1, kVertex2, kEdge01, kEdge12, kEdge20, kFace };

struct ClosestPointOnTriangle {
  Vector3 point = Vector3::Zero();
  // Barycentric coordinates of point: point = (1 - u - v) v0 + u v1 + v v2.
  double u = 0;
  double v = 0;
  TriangleFeature feature = TriangleFeature::kFace;
  double distance_squared = 0;
};

// Non-finite input (in p or a corner) gives NaN point, barycentrics and distance.
ClosestPointOnTriangle FindClosestPointOnTriangle(const Vector3& p, const Triangle& tri);

}  // namespace hapticd::geometry
