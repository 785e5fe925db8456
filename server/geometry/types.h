#pragma once

// Common value types of the geometry core. Everything is double precision, SI units
// (metres), and expressed in one frame that the caller names (usually the world W).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hapticd::geometry {

using Vector2 = Eigen::Vector2d;
using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;

// A triangle by its three corners, in the order that defines its normal:
// n = (v1 - v0) x (v2 - v0) (counter-clockwise seen from the side n points to).
struct Triangle {
  Vector3 v0, v1, v2;
};

// A solid ball. radius >= 0.
struct Sphere {
  Vector3 center = Vector3::Zero();
  double radius = 0;
};

// An oriented box: the columns of rotation (R_WB) are the box's unit axes in the
// frame, half_extents >= 0 along each of them.
struct Box {
  Vector3 center = Vector3::Zero();
  Matrix3 rotation = Matrix3::Identity();
  Vector3 half_extents = Vector3::Zero();
};

// All points within radius of the segment p0-p1 (a sphere when p0 == p1).
struct Capsule {
  Vector3 p0 = Vector3::Zero();
  Vector3 p1 = Vector3::Zero();
  double radius = 0;
};

}  // namespace hapticd::geometry
