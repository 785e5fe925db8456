#pragma once

// Capsule versus oriented box. The core is an exact closest-point search between a
// segment and a box (a convex piecewise quadratic minimised piece by piece); the
// capsule adds its radius. When the segment enters the box, the penetration depth is
// the true one (the shortest translation that separates them).

#include "server/geometry/types.h"

namespace hapticd::geometry {

// Closest points between the segment p0-p1 and a box, in the frame of the input.
struct SegmentBoxClosestPoints {
  // Parameter of the segment point: point_segment = p0 + t (p1 - p0), t in [0, 1].
  double t = 0;
  Vector3 point_segment = Vector3::Zero();
  // The box point nearest point_segment (point_segment itself when inside the box).
  Vector3 point_box = Vector3::Zero();
  // |point_segment - point_box|^2; 0 when the segment touches or enters the box.
  double distance_squared = 0;
};

// Finds the segment point nearest the box and the box point nearest it. Where several
// segment points are equally near (a segment parallel to a face, or through the box)
// one of them is returned: the middle of the first such stretch.
// Preconditions: orthonormal rotation, half_extents >= 0; p0 == p1 is fine (a point).
// A NaN or infinity in p0, p1 or the box (centre, rotation, half extents) finds
// nothing: t 0, both points zero and distance_squared the largest finite double, so
// that no radius reaches it.
SegmentBoxClosestPoints FindClosestPointsSegmentBox(const Vector3& p0, const Vector3& p1,
                                                    const Box& box);

struct CapsuleBoxResult {
  // True when the closed capsule and the closed box share a point.
  bool intersect = false;
  // Signed: > 0 the gap, < 0 minus the penetration depth. While the capsule's segment
  // stays outside the box the depth is radius - (segment-box distance); once the
  // segment touches or enters the box it is radius + the segment's own penetration
  // depth (the shortest translation that takes the segment out of the box). Both are
  // the true penetration depth of the capsule. A segment within 1e-12 of the scale of
  // the input (coordinates in the box frame) counts as touching.
  double distance = 0;
  // Unit, from the box towards the capsule: translating the capsule by
  // -distance * normal makes them touch. While the segment is inside, a face normal
  // of the box or a normal of a box edge and the segment (box edge x segment). Zero
  // only for non-finite input (below).
  Vector3 normal = Vector3::UnitX();
  // point_box: the box point nearest the capsule (when the segment is inside: where
  // the separated segment would touch the box). point_capsule: the capsule point
  // nearest the box or deepest inside it along -normal. |point_capsule - point_box| ==
  // |distance| up to rounding.
  Vector3 point_box = Vector3::Zero();
  Vector3 point_capsule = Vector3::Zero();
};

// Collides a capsule with a box given in the same frame. Preconditions: as for
// FindClosestPointsSegmentBox, and radius >= 0. Ties between exit directions of a
// penetrating segment go to the box faces (x, y, z, each + before -), then the edge
// normals. A NaN or infinity in the capsule (p0, p1, radius) or the box gives no
// contact: intersect false, distance 0, and the normal and both points zero (the one
// answer whose normal is not unit, so that any force made from it is zero).
CapsuleBoxResult CollideCapsuleBox(const Capsule& capsule, const Box& box);

}  // namespace hapticd::geometry
