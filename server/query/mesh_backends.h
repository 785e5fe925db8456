#pragma once

// The backends that answer a mesh's queries, one row each: the native BVH and Embree's
// BVH deciding with the same exact tests (server/embree; the same answers). Every
// caller asks BackendOf(mesh) for its row, so adding a backend is one row here and one
// enumerator in scene::RayBackend.

#include <span>
#include <string_view>

#include "server/geometry/mesh_queries.h"
#include "server/geometry/sphere_sweep.h"
#include "server/scene/shape.h"

namespace hapticd::query {

using geometry::Vector3;

struct MeshBackend {
  scene::RayBackend id;
  // geometry::FindClosestPointOnMesh's contract.
  geometry::MeshClosestPoint (*closest_point)(const scene::MeshShape& mesh, const Vector3& p,
                                              double max_distance);
  // geometry::CalcSignedDistanceToMesh's contract.
  geometry::MeshSignedDistance (*signed_distance)(const scene::MeshShape& mesh, const Vector3& p);
  // geometry::IsPointInsideMesh's contract.
  bool (*is_inside)(const scene::MeshShape& mesh, const Vector3& p);
  // geometry::FindFirstSegmentHit's contract.
  geometry::SegmentMeshHit (*first_segment_hit)(const scene::MeshShape& mesh, const Vector3& p,
                                                const Vector3& q);
  // out[i] = first_segment_hit(mesh, p[i], q[i]) for the first min(sizes) segments
  // (Embree traces them in packets).
  void (*first_segment_hits)(const scene::MeshShape& mesh, std::span<const Vector3> p,
                             std::span<const Vector3> q, std::span<geometry::SegmentMeshHit> out);
  // geometry::SweepSphereMesh's contract.
  geometry::SphereSweepHit (*sweep_sphere)(const scene::MeshShape& mesh, const Vector3& a,
                                           const Vector3& b, double r);
  // geometry::FindSphereMeshContacts's contract: every triangle within the closed sphere.
  geometry::SphereMeshContacts (*sphere_contacts)(const scene::MeshShape& mesh,
                                                  const geometry::Sphere& sphere,
                                                  std::span<geometry::SphereMeshContact> out);
};

// The row of the backend mesh is on (Embree when it holds an Embree scene).
const MeshBackend& BackendOf(const scene::MeshShape& mesh);

}  // namespace hapticd::query
