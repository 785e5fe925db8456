#pragma once

// Sphere-sphere contact: intersection, signed distance, normal and witness points.
// Closed balls: spheres that touch intersect, and the intersect decision is exact.

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SphereSphereResult {
  // True when the closed balls share a point (touching counts). Decided exactly.
  bool intersect = false;
  // Signed: > 0 the gap between the surfaces, < 0 minus the penetration depth
  // (the length of the shortest translation that separates them, ra + rb - |cb - ca|).
  double distance = 0;
  // Unit, from a towards b: translating b by -distance * normal makes them touch.
  // Zero only for non-finite input (see CollideSpheres).
  Vector3 normal = Vector3::UnitX();
  // point_a: the point of a nearest b (deepest into b when they overlap); point_b
  // likewise. |point_b - point_a| == |distance| up to rounding.
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
};

// The distance between centres a and b, and the unit vector from a towards b: +x where
// they coincide or their distance underflows (CollideSpheres' normal for finite input).
struct CenterLine {
  double distance = 0;
  Vector3 direction = Vector3::UnitX();
};
inline CenterLine CalcCenterLine(const Vector3& a, const Vector3& b) {
  const Vector3 delta = b - a;
  const double d = delta.norm();
  return {d, d > 0 ? Vector3(delta / d) : Vector3::UnitX()};
}

// Collides two spheres given in one frame. Preconditions: radii >= 0. Concentric
// spheres have no preferred direction: the normal is then +x, by convention, and
// distance = -(ra + rb). A NaN or infinity in either centre or radius gives no
// contact: intersect false, distance 0, and the normal and both points zero (the one
// answer whose normal is not unit, so that any force made from it is zero). Finite
// input whose squares overflow (magnitudes beyond about 1e150) gives unspecified values.
SphereSphereResult CollideSpheres(const Sphere& a, const Sphere& b);

// Exact sign of |cb - ca|^2 - (ra + rb)^2: -1 or 0 when the closed balls intersect.
// Preconditions: radii >= 0; the answer is right for every finite input whose squares
// neither overflow nor underflow (magnitudes within about 1e-140..1e140), and 0 where
// finite squares overflow. A NaN or infinity anywhere gives +1, apart, as above.
int CompareCenterDistanceToRadiusSum(const Sphere& a, const Sphere& b);

}  // namespace hapticd::geometry
