#pragma once

// Closest point on an EmbreeMesh through rtcPointQuery. Embree's traversal hands over
// every primitive whose grown box (embree_mesh.h) lies within the query radius of the
// point; a callback computes the exact double-precision closest point on each
// (FindClosestPointOnTriangle) and shrinks the radius to the best distance so far,
// rounded up to float. The guard covers rounding the point to float, so no triangle
// within the best distance is skipped and the answer equals the native one.
//
// Thread-safe, allocation-free, never throws. The point is in the mesh's frame.

#include <limits>

#include "server/embree/embree_mesh.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

// The point of the mesh closest to p within max_distance (closed), as
// geometry::FindClosestPointOnMesh: infinite max_distance searches everywhere; negative
// or NaN max_distance, or a non-finite p, finds nothing; where several points tie, any
// one. A point beyond the mesh's trust bound is answered by the native BVH.
geometry::MeshClosestPoint FindClosestPointOnMesh(
    const EmbreeMesh& mesh, const geometry::Vector3& p,
    double max_distance = std::numeric_limits<double>::infinity());

namespace internal {

// Which side of the surface p lies on, judged from one candidate closest point (its
// triangle, feature and point): true for the outside. See embree_signed_distance.cc.
using SideOfCandidate = bool (*)(const geometry::TriangleMesh& mesh, const geometry::Vector3& p,
                                 const geometry::MeshClosestPoint& candidate);

struct ClosestPointSides {
  geometry::MeshClosestPoint closest;
  // Some candidates exactly as close as `closest` (ties, any of which the native query
  // may report) lie on different sides by the SideOfCandidate given.
  bool sides_differ = false;
};

// FindClosestPointOnMesh(mesh, p) through Embree that also judges `side` on the best
// candidate and every exact tie of it. Precondition: mesh.IsTrustedPoint(p).
ClosestPointSides FindClosestPointAndSides(const EmbreeMesh& mesh, const geometry::Vector3& p,
                                           SideOfCandidate side);

}  // namespace internal
}  // namespace hapticd::embree
