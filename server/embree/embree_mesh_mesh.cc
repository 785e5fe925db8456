#include "server/embree/embree_mesh_mesh.h"

#include <algorithm>
#include <atomic>

#include "server/geometry/aabb.h"
#include "server/geometry/triangle_triangle.h"

namespace hapticd::embree {
namespace {

using geometry::Aabb;
using geometry::MeshMeshContact;
using geometry::MeshMeshContacts;

// What the collision callback reads and fills; Embree may call it from several
// threads at once.
struct CollideSearch {
  const EmbreeMesh* a = nullptr;
  const EmbreeMesh* b = nullptr;
  std::span<MeshMeshContact> out;
  bool stop_at_first = false;
  std::atomic<int> num_pairs{0};
  std::atomic<bool> found{false};
};

// Decides a batch of candidate pairs exactly.
void VisitCandidates(void* user, RTCCollision* collisions, unsigned num_collisions) {
  auto& search = *static_cast<CollideSearch*>(user);
  for (unsigned k = 0; k < num_collisions; ++k) {
    // one touching pair answers MeshesIntersect: skip the rest
    if (search.stop_at_first && search.found.load(std::memory_order_relaxed)) return;
    const geometry::Triangle& ta = search.a->primitive(collisions[k].primID0);
    const geometry::Triangle& tb = search.b->primitive(collisions[k].primID1);
    // boxes apart (exact comparisons): no contact
    if (!geometry::AabbsOverlap(Aabb::OfTriangle(ta), Aabb::OfTriangle(tb))) continue;
    if (search.stop_at_first) {
      if (geometry::TrianglesIntersect(ta, tb)) search.found.store(true);
      continue;
    }
    const geometry::TriangleIntersection x = geometry::IntersectTriangles(ta, tb);
    if (!x.intersect) continue;
    // claim a slot; past the end only the count grows
    const int slot = search.num_pairs.fetch_add(1);
    if (slot >= static_cast<int>(search.out.size())) continue;
    search.out[slot] = {search.a->primitive_triangle(collisions[k].primID0),
                        search.b->primitive_triangle(collisions[k].primID1), x.coplanar, x.p0,
                        x.p1};
  }
}

// rtcCollide needs two distinct scenes of one device.
bool CanCollide(const EmbreeMesh& a, const EmbreeMesh& b) {
  return &a != &b && a.device().handle() == b.device().handle();
}

}  // namespace

MeshMeshContacts FindMeshMeshContacts(const EmbreeMesh& a, const EmbreeMesh& b,
                                      std::span<MeshMeshContact> out) {
  if (!CanCollide(a, b)) {
    return geometry::FindMeshMeshContacts(a.bvh(), b.bvh(), Eigen::Isometry3d::Identity(), out);
  }
  CollideSearch search;
  search.a = &a;
  search.b = &b;
  search.out = out;
  rtcCollide(a.scene(), b.scene(), &VisitCandidates, &search);
  MeshMeshContacts result;
  result.num_pairs = search.num_pairs.load();
  result.count = std::min(result.num_pairs, static_cast<int>(out.size()));
  result.truncated = result.num_pairs > result.count;
  return result;
}

bool MeshesIntersect(const EmbreeMesh& a, const EmbreeMesh& b) {
  if (!CanCollide(a, b)) {
    return geometry::MeshesIntersect(a.bvh(), b.bvh(), Eigen::Isometry3d::Identity());
  }
  CollideSearch search;
  search.a = &a;
  search.b = &b;
  search.stop_at_first = true;
  rtcCollide(a.scene(), b.scene(), &VisitCandidates, &search);
  return search.found.load();
}

}  // namespace hapticd::embree
