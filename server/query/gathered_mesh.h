#pragma once

// A mesh's queries asked of the triangles gathered near a point instead of the whole
// mesh (query::Neighbourhood gathers them once per tick; SweepSphereShape and its
// nearest-triangle bound then ask here).
//
// Theory of operation. The gathered triangles hold every triangle within radius of a
// segment (a ball when its ends are equal), so every triangle left out is farther than
// radius from the segment. A query whose answer lies within radius - (p's distance from
// the segment) of its point p (less a slack) can then only be answered by gathered
// triangles: the answer over them is the answer over the mesh. Otherwise the query says
// so (nullopt) and the caller asks the mesh's backend. The decisions are the mesh queries' own, on the same double-precision
// triangles; only the choice among exact ties (several triangles equally near, or
// touched at the same t) may name another triangle than a BVH traversal would.

#include <optional>
#include <span>

#include "server/geometry/mesh_queries.h"
#include "server/geometry/point_segment.h"
#include "server/geometry/sphere_sweep.h"

namespace hapticd::query {

using geometry::Vector3;

// The triangles of one mesh within region_B.radius of the segment region_B.p0 -> p1 (the
// mesh's body frame), as geometry::GatherMeshTriangles found them; radius < 0: none
// gathered.
struct GatheredMesh {
  std::span<const geometry::PreparedTriangle> triangles;
  geometry::Capsule region_B{Vector3::Zero(), Vector3::Zero(), -1};
  bool gathered() const { return region_B.radius >= 0; }
};

// What an answer must lie inside the gathered region by (m) to be the mesh's: far above
// the rounding of the distances and the frames' changes and above the queries' own
// tolerances (1e-8 m at most: a resting sphere's gap), far below any margin worth
// gathering.
inline constexpr double kGatheredSlack = 1e-6;

// geometry::FindClosestPointOnMesh(p_B, max_distance) from the gathered triangles (of
// equally near ones, the first in the span), or nullopt when a triangle left out could be
// nearer. Charges the work meter one unit per exact closest point and one per eight
// triangles passed over. Real-time safe.
std::optional<geometry::MeshClosestPoint> FindGatheredClosestPoint(const GatheredMesh& near, const Vector3& p_B,
                                                                   double max_distance);

// geometry::SweepSphereMesh(a_B, b_B, r) from the gathered triangles (of simultaneous
// hits, the first in the span), or nullopt when a triangle left out could be touched
// first. Real-time safe.
std::optional<geometry::SphereSweepHit> SweepGatheredSphere(const GatheredMesh& near, const Vector3& a_B,
                                                            const Vector3& b_B, double r);

}  // namespace hapticd::query
