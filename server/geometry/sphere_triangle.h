#pragma once

// Sphere-triangle contact for the sphere avatar: whether they touch, how deep, which
// way to push the sphere out, and where on the triangle (with the feature and the
// barycentric coordinates that force shading interpolates normals with).

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SphereTriangleContact {
  // distance <= radius: closed sets, so a sphere that just touches the triangle counts.
  bool touching = false;
  // From the centre to the triangle, >= 0.
  double distance = 0;
  // radius - distance: >= 0 exactly when touching, the gap (negated) otherwise.
  double depth = 0;
  // Unit, from the triangle towards the centre: the direction that pushes the sphere
  // out of the triangle. On a face it is ± the face normal, the sign decided exactly.
  Vector3 normal = Vector3::UnitZ();
  // The centre lies exactly on the (closed) triangle, so the push direction is
  // undefined; normal is then the face normal (v1 - v0) x (v2 - v0), normalized.
  bool centre_on_triangle = false;
  // The closest point of the triangle to the centre (the contact point), with its
  // barycentric coordinates (point = (1 - u - v) v0 + u v1 + v v2) and feature.
  Vector3 point = Vector3::Zero();
  double u = 0;
  double v = 0;
  TriangleFeature feature = TriangleFeature::kFace;
};

// The contact between a sphere (radius >= 0) and a triangle, both in one frame (m).
// Filled in whether or not they touch. Preconditions: finite input, a non-degenerate
// triangle; a degenerate triangle still gives distance and point (to the segment or
// point it collapses to) but an unspecified unit normal. Non-finite input: touching
// is false, the other fields are unspecified.
SphereTriangleContact CalcSphereTriangleContact(const Sphere& sphere, const Triangle& tri);

}  // namespace hapticd::geometry
