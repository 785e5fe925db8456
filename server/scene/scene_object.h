#pragma once

// One object of a scene snapshot: its shape in its body frame B, where B is, how it
// feels, and how it moves.

#include <cstdint>
#include <string>

#include "server/geometry/aabb.h"
#include "server/scene/material.h"
#include "server/scene/mesh_representation.h"
#include "server/scene/pose.h"
#include "server/scene/shape.h"

namespace hapticd::scene {

enum class Motion {
  kStatic,     // never moves
  kKinematic,  // moved by clients; its velocity is known, so a resting proxy is carried along
};

struct SceneObject {
  std::string name;
  Shape shape;
  Pose X_WB;
  Material material;
  Motion motion = Motion::kStatic;
  // Kinematic objects: velocity of B's origin and angular velocity, both in W (zero for
  // static objects). A point p_W of the body moves at v_WB + w_WB x (p_W - p_WB).
  Vector3 v_WB = Vector3::Zero();
  Vector3 w_WB = Vector3::Zero();
  // For objects added as meshes: what represents the mesh and how far it may be from it.
  RepresentationChoice representation;
  // Box around the placed shape in W (CalcWorldBounds), for culling.
  geometry::Aabb bounds_W;
  // DigestShape(shape, representation), set when the object is made: readers caching
  // its geometry tell a changed shape by it.
  uint64_t shape_digest = 0;

  // Velocity in W of the body point now at p_W.
  Vector3 CalcPointVelocity(const Vector3& p_W) const {
    return v_WB + w_WB.cross(p_W - X_WB.translation);
  }
};

}  // namespace hapticd::scene
