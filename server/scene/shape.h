#pragma once

// The shapes a scene object can have, each in its own body frame B. Shared, immutable
// geometry (hulls, meshes with their BVH) is held by shared_ptr so that successive
// scene snapshots share it instead of copying.

#include <memory>
#include <string_view>
#include <variant>

#include "server/geometry/aabb.h"
#include "server/geometry/bvh.h"
#include "server/geometry/convex_hull.h"
#include "server/scene/pose.h"

namespace hapticd::embree {
class EmbreeMesh;
}  // namespace hapticd::embree

namespace hapticd::scene {

// A ball of radius > 0 centred on B's origin.
struct SphereShape {
  double radius = 0;
};
// A box centred on B's origin, aligned with B's axes, half_extents > 0.
struct BoxShape {
  Vector3 half_extents = Vector3::Zero();
};
// All points within radius > 0 of the segment from (0, 0, -half_length) to
// (0, 0, half_length) of B (half_length >= 0).
struct CapsuleShape {
  double radius = 0;
  double half_length = 0;
};
// The half-space z <= 0 of B: B's +z axis is the outward normal, B's origin on the surface.
struct PlaneShape {};
// A convex polyhedron: the hull (dimension 3) of points given in B.
struct ConvexShape {
  std::shared_ptr<const geometry::ConvexHull> hull;
};
// Which code answers a mesh's segment and closest-point queries: the native BVH, or
// Embree's BVH deciding with the same exact tests (server/embree; same answers).
enum class RayBackend { kNative, kEmbree, kCount };
// "native", "embree".
std::string_view RayBackendName(RayBackend backend);

// A triangle mesh in B with its BVH. Closed meshes are solids (inside means something;
// validation rewound them so their normals point out); open meshes are surfaces with
// no inside: distances to them are unsigned, and they block rays and proxies from
// either side (force/shape_queries.h). With the Embree backend, `embree` is the same
// mesh in an Embree scene (null for native).
struct MeshShape {
  std::shared_ptr<const geometry::MeshBvh> bvh;
  std::shared_ptr<const embree::EmbreeMesh> embree = nullptr;
};

using Shape = std::variant<SphereShape, BoxShape, CapsuleShape, PlaneShape, ConvexShape, MeshShape>;

enum class ShapeType { kSphere, kBox, kCapsule, kPlane, kConvex, kMesh, kCount };

inline ShapeType TypeOf(const Shape& shape) { return static_cast<ShapeType>(shape.index()); }
// "sphere", "box", "capsule", "plane", "convex", "mesh" (the scenario format's names).
std::string_view ShapeTypeName(ShapeType type);

// Box around the shape placed at X_WB, in W. A plane's box is that of its half-space:
// unbounded, except on the outer side along a world axis that is the plane's normal.
geometry::Aabb CalcWorldBounds(const Shape& shape, const Pose& X_WB);

}  // namespace hapticd::scene
