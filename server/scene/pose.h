#pragma once

// A rigid pose X_WB: the body frame B placed in the world W, p_W = R_WB p_B + p_WB.

#include "server/geometry/types.h"

namespace hapticd::scene {

using geometry::Matrix3;
using geometry::Vector3;

struct Pose {
  Matrix3 rotation = Matrix3::Identity();    // R_WB: columns are B's axes in W
  Vector3 translation = Vector3::Zero();     // p_WB: B's origin in W

  // A point or direction of B, expressed in W.
  Vector3 ToWorld(const Vector3& p_B) const { return rotation * p_B + translation; }
  Vector3 DirectionToWorld(const Vector3& d_B) const { return rotation * d_B; }
  // A point or direction of W, expressed in B.
  Vector3 ToBody(const Vector3& p_W) const { return rotation.transpose() * (p_W - translation); }
  Vector3 DirectionToBody(const Vector3& d_W) const { return rotation.transpose() * d_W; }
};

}  // namespace hapticd::scene
