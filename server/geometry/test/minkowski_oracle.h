#pragma once

// The convex tests' independent oracle: the convex hull of the Minkowski difference
// D = {b_j - a_i} of two point sets. The shapes touch or overlap exactly when D holds
// the origin; outside, their distance is the origin's distance to D's nearest face;
// inside, the penetration depth is the least distance from the origin to a face plane.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/convex_hull.h"

namespace hapticd::geometry {

inline std::vector<Vector3> MinkowskiDifference(const std::vector<Vector3>& a,
                                                const std::vector<Vector3>& b) {
  std::vector<Vector3> diff;
  for (const Vector3& p : a) {
    for (const Vector3& q : b) diff.push_back(q - p);
  }
  return diff;
}

// Signed distance (minus the depth inside) of the two hulls; NaN when D is flat.
inline double OracleSignedDistance(const std::vector<Vector3>& a, const std::vector<Vector3>& b) {
  const ConvexHull d = BuildConvexHull(MinkowskiDifference(a, b));
  if (d.dimension != 3) return std::numeric_limits<double>::quiet_NaN();
  // the largest plane distance of the origin: <= 0 inside, where it is minus the depth
  double outside = -std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < d.faces.size(); ++f) {
    outside = std::max(outside, -d.face_normals[f].dot(d.vertices[d.faces[f][0]]));
  }
  if (outside <= 0) return outside;
  double nearest = std::numeric_limits<double>::infinity();
  for (const auto& f : d.faces) {
    const Triangle t{d.vertices[f[0]], d.vertices[f[1]], d.vertices[f[2]]};
    nearest = std::min(nearest, FindClosestPointOnTriangle(Vector3::Zero(), t).distance_squared);
  }
  return std::sqrt(nearest);
}

}  // namespace hapticd::geometry
