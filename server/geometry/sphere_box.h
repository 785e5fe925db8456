#pragma once

// Sphere versus oriented box: intersection, signed distance, normal and witness
// points. Closed sets: a sphere that touches the box intersects it.

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SphereBoxResult {
  // True when the closed ball and the closed box share a point. Decided in floating
  // point on the box-frame centre: exact for an identity rotation when the squares
  // are exact (dyadic data); for a rotated box the touching case is as exact as
  // R^T (c - center) is (a few ulps).
  bool intersect = false;
  // Signed: > 0 the gap between them, < 0 minus the penetration depth (the length of
  // the shortest translation of the sphere that separates them).
  double distance = 0;
  // Unit, from the box towards the sphere: translating the sphere by
  // -distance * normal makes them touch. Zero only for non-finite input (below).
  Vector3 normal = Vector3::UnitX();
  // point_box: the point of the box nearest the sphere (when the centre is inside,
  // the point of the exit face the centre projects to). point_sphere: the point of
  // the sphere nearest the box, or deepest inside it. |point_sphere - point_box| ==
  // |distance| up to rounding.
  Vector3 point_box = Vector3::Zero();
  Vector3 point_sphere = Vector3::Zero();
};

// Collides a sphere with a box given in the same frame. Preconditions: radius >= 0,
// half_extents >= 0, box.rotation orthonormal. A centre inside the box (or on its
// surface) exits through the nearest face; on a tie between faces the lowest axis
// wins, and the + face when the centre is exactly mid-way. A NaN or infinity in the
// sphere (centre, radius) or the box (centre, rotation, half extents) gives no
// contact: intersect false, distance 0, and the normal and both points zero (the one
// answer whose normal is not unit, so that any force made from it is zero).
SphereBoxResult CollideSphereBox(const Sphere& sphere, const Box& box);

}  // namespace hapticd::geometry
