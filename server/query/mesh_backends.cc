#include "server/query/mesh_backends.h"

#include <array>

#include "server/embree/embree_closest_point.h"
#include "server/embree/embree_segment_queries.h"
#include "server/embree/embree_signed_distance.h"
#include "server/embree/embree_sphere_sweep.h"

namespace hapticd::query {
namespace {

using scene::MeshShape;

void NativeFirstSegmentHits(const MeshShape& mesh, std::span<const Vector3> p, std::span<const Vector3> q,
                            std::span<geometry::SegmentMeshHit> out) {
  const std::size_t n = std::min({p.size(), q.size(), out.size()});
  for (std::size_t i = 0; i < n; ++i) out[i] = geometry::FindFirstSegmentHit(*mesh.bvh, p[i], q[i]);
}

geometry::SphereMeshContacts NativeSphereContacts(const MeshShape& mesh, const geometry::Sphere& sphere,
                                                  std::span<geometry::SphereMeshContact> out) {
  return geometry::FindSphereMeshContacts(*mesh.bvh, sphere, out);
}

constexpr MeshBackend kNative{
    .id = scene::RayBackend::kNative,
    .closest_point = [](const MeshShape& mesh, const Vector3& p, double max_distance) {
      return geometry::FindClosestPointOnMesh(*mesh.bvh, p, max_distance);
    },
    .signed_distance = [](const MeshShape& mesh, const Vector3& p) {
      return geometry::CalcSignedDistanceToMesh(*mesh.bvh, p);
    },
    .is_inside = [](const MeshShape& mesh, const Vector3& p) { return geometry::IsPointInsideMesh(*mesh.bvh, p); },
    .first_segment_hit = [](const MeshShape& mesh, const Vector3& p, const Vector3& q) {
      return geometry::FindFirstSegmentHit(*mesh.bvh, p, q);
    },
    .first_segment_hits = NativeFirstSegmentHits,
    .sweep_sphere = [](const MeshShape& mesh, const Vector3& a, const Vector3& b, double r) {
      return geometry::SweepSphereMesh(*mesh.bvh, a, b, r);
    },
    .sphere_contacts = NativeSphereContacts,
};

// Embree has no query for every triangle within a sphere; the native BVH (which every
// Embree mesh keeps) answers it.
constexpr MeshBackend kEmbree{
    .id = scene::RayBackend::kEmbree,
    .closest_point = [](const MeshShape& mesh, const Vector3& p, double max_distance) {
      return embree::FindClosestPointOnMesh(*mesh.embree, p, max_distance);
    },
    .signed_distance = [](const MeshShape& mesh, const Vector3& p) {
      return embree::CalcSignedDistanceToMesh(*mesh.embree, p);
    },
    .is_inside = [](const MeshShape& mesh, const Vector3& p) { return embree::IsPointInsideMesh(*mesh.embree, p); },
    .first_segment_hit = [](const MeshShape& mesh, const Vector3& p, const Vector3& q) {
      return embree::FindFirstSegmentHit(*mesh.embree, p, q);
    },
    .first_segment_hits = [](const MeshShape& mesh, std::span<const Vector3> p, std::span<const Vector3> q,
                             std::span<geometry::SegmentMeshHit> out) {
      embree::FindFirstSegmentHits(*mesh.embree, p, q, out);
    },
    .sweep_sphere = [](const MeshShape& mesh, const Vector3& a, const Vector3& b, double r) {
      return embree::SweepSphereMesh(*mesh.embree, a, b, r);
    },
    .sphere_contacts = NativeSphereContacts,
};

constexpr std::array<const MeshBackend*, static_cast<int>(scene::RayBackend::kCount)> kBackends = {&kNative,
                                                                                                   &kEmbree};
static_assert(kNative.id == scene::RayBackend::kNative && kEmbree.id == scene::RayBackend::kEmbree);

}  // namespace

const MeshBackend& BackendOf(const MeshShape& mesh) {
  return *kBackends[static_cast<int>(mesh.embree ? scene::RayBackend::kEmbree : scene::RayBackend::kNative)];
}

}  // namespace hapticd::query
