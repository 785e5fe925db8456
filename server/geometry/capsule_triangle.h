#pragma once

// Capsule-triangle contact: the closest points of the capsule's axis segment and the
// triangle, the depth, and the direction that pushes the capsule out. The tool
// avatar's shafts are capsules.

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct CapsuleTriangleContact {
  // depth >= 0: closed sets, so a capsule that just touches the triangle counts.
  bool touching = false;
  // The axis segment crosses or touches the triangle, transversally (not in-plane).
  bool axis_crosses = false;
  // The axis lies in the triangle's plane and meets the triangle; normal is then the
  // face normal (v1 - v0) x (v2 - v0), normalized.
  bool axis_in_plane = false;
  // From the axis segment to the triangle, >= 0; 0 when the axis meets the triangle.
  double distance = 0;
  // How far to move the capsule along normal to clear the triangle: radius - distance
  // when the axis does not cross the triangle (negative: the gap), otherwise radius
  // plus the axis' own penetration depth, the shortest translation that frees the
  // axis segment from the triangle.
  double depth = 0;
  // Unit direction to move the capsule out of the triangle. Without crossing it points
  // from point_on_triangle towards point_on_axis (when they differ).
  Vector3 normal = Vector3::UnitZ();
  // The witness points: the closest points when the axis does not cross the triangle;
  // when it does, the axis point that the shortest translation moves onto the
  // triangle's boundary, and where it lands:
  // point_on_triangle = point_on_axis + (depth - radius) normal.
  Vector3 point_on_axis = Vector3::Zero();
  Vector3 point_on_triangle = Vector3::Zero();
  // point_on_axis = p0 + s (p1 - p0), s in [0, 1].
  double s = 0;
};

// The contact between a capsule (radius >= 0, p0 == p1 allowed) and a triangle, in
// one frame (m). Filled in whether or not they touch. Preconditions: finite input, a
// non-degenerate triangle (otherwise: no crash, unspecified normal and depth).
// Non-finite input: touching is false, the other fields are unspecified.
CapsuleTriangleContact CalcCapsuleTriangleContact(const Capsule& capsule, const Triangle& tri);

}  // namespace hapticd::geometry
