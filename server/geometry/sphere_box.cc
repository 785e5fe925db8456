#include "server/geometry/sphere_box.h"

#include <cmath>

namespace hapticd::geometry {
namespace {

bool IsFinite(const Sphere& sphere, const Box& box) {
  return sphere.center.allFinite() && std::isfinite(sphere.radius) && box.center.allFinite() &&
         box.rotation.allFinite() && box.half_extents.allFinite();
}

}  // namespace

SphereBoxResult CollideSphereBox(const Sphere& sphere, const Box& box) {
  SphereBoxResult result;
  // Non-finite input: no contact, every field zero (the normal included).
  if (!IsFinite(sphere, box)) {
    result.normal = Vector3::Zero();
    return result;
  }
  const Matrix3& R_WB = box.rotation;
  const Vector3& h = box.half_extents;
  // The centre in the box frame B.
  const Vector3 p_BC = R_WB.transpose() * (sphere.center - box.center);
  const Vector3 p_BQ = p_BC.cwiseMax(-h).cwiseMin(h);
  const bool outside = (p_BC.array().abs() > h.array()).any();

  Vector3 n_B;
  double gap;
  double gap_squared = 0;
  Vector3 q_B = p_BQ;
  if (outside) {
    // Centre outside: the nearest box point is the clamped centre.
    const Vector3 diff = p_BC - p_BQ;
    gap_squared = diff.squaredNorm();
    gap = std::sqrt(gap_squared);
    if (gap > 0) {
      n_B = diff / gap;
    } else {
      // Degenerate: the offset is non-zero but its square underflows; use the
      // largest component's axis.
      int axis;
      diff.cwiseAbs().maxCoeff(&axis);
      n_B = Vector3::Unit(axis) * (diff[axis] > 0 ? 1.0 : -1.0);
    }
  } else {
    // Centre inside or on the surface: exit through the face nearest the centre.
    const Vector3 depth = h - p_BC.cwiseAbs();
    int axis = 0;
    for (int i = 1; i < 3; ++i) {
      if (depth[i] < depth[axis]) axis = i;
    }
    // Exactly at the middle of that axis: the + face.
    const double side = p_BC[axis] < 0 ? -1.0 : 1.0;
    n_B = Vector3::Unit(axis) * side;
    q_B[axis] = side * h[axis];
    gap = -depth[axis];
  }

  // Back to the world frame.
  result.normal = R_WB * n_B;
  result.distance = gap - sphere.radius;
  result.intersect = outside ? gap_squared <= sphere.radius * sphere.radius : true;
  result.point_box = box.center + R_WB * q_B;
  result.point_sphere = sphere.center - sphere.radius * result.normal;
  return result;
}

}  // namespace hapticd::geometry
