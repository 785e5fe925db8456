#include "server/scene/shape.h"

#include <limits>
#include <type_traits>

namespace hapticd::scene {
namespace {

using geometry::Aabb;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Box in W around a box of B given by centre c_B and half extents h: the rotated box's
// extent along each world axis is sum_j |R_ij| h_j (exact for a box).
Aabb RotatedBox(const Vector3& c_B, const Vector3& h, const Pose& X_WB) {
  const Vector3 c_W = X_WB.ToWorld(c_B);
  const Vector3 e_W = X_WB.rotation.cwiseAbs() * h;
  return {c_W - e_W, c_W + e_W};
}

// The half-space z_B <= 0: unbounded, except on the outer side of a normal that is
// exactly a world axis.
Aabb PlaneBounds(const Pose& X_WB) {
  Aabb box{Vector3::Constant(-kInf), Vector3::Constant(kInf)};
  const Vector3 n_W = X_WB.rotation.col(2);
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    // tilted planes reach every point of every axis
    if (n_W[a] != 0 || n_W[b] != 0) continue;
    if (n_W[k] > 0) box.max[k] = X_WB.translation[k];
    if (n_W[k] < 0) box.min[k] = X_WB.translation[k];
  }
  return box;
}

}  // namespace

std::string_view RayBackendName(RayBackend backend) {
  switch (backend) {
    case RayBackend::kNative: return "native";
    case RayBackend::kEmbree: return "embree";
    case RayBackend::kCount: break;
  }
  return "unknown";
}

std::string_view ShapeTypeName(ShapeType type) {
  switch (type) {
    case ShapeType::kSphere: return "sphere";
    case ShapeType::kBox: return "box";
    case ShapeType::kCapsule: return "capsule";
    case ShapeType::kPlane: return "plane";
    case ShapeType::kConvex: return "convex";
    case ShapeType::kMesh: return "mesh";
    case ShapeType::kCount: break;
  }
  return "unknown";
}

geometry::Aabb CalcWorldBounds(const Shape& shape, const Pose& X_WB) {
  return std::visit(
      [&](const auto& s) -> Aabb {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, SphereShape>) {
          const Vector3 r = Vector3::Constant(s.radius);
          return {X_WB.translation - r, X_WB.translation + r};
        } else if constexpr (std::is_same_v<S, BoxShape>) {
          return RotatedBox(Vector3::Zero(), s.half_extents, X_WB);
        } else if constexpr (std::is_same_v<S, CapsuleShape>) {
          // the axis' extent plus the radius on every side
          const Vector3 e_W = X_WB.rotation.col(2).cwiseAbs() * s.half_length +
                              Vector3::Constant(s.radius);
          return {X_WB.translation - e_W, X_WB.translation + e_W};
        } else if constexpr (std::is_same_v<S, PlaneShape>) {
          return PlaneBounds(X_WB);
        } else if constexpr (std::is_same_v<S, ConvexShape>) {
          // the hull's own vertices, placed: exact
          Aabb box;
          if (!s.hull) return box;
          for (const Vector3& p_B : s.hull->vertices) box.Extend(X_WB.ToWorld(p_B));
          return box;
        } else {
          // a mesh may be large: the rotated box of its body-frame box
          if (!s.bvh) return Aabb{};
          const Aabb& b = s.bvh->mesh().bounds();
          return RotatedBox(b.center(), 0.5 * b.size(), X_WB);
        }
      },
      shape);
}

}  // namespace hapticd::scene
