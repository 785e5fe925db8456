#pragma once

// Queries of one triangle mesh through its BVH: segment casts, closest points, sphere
// contacts and inside/outside. Every decision is made on the double-precision
// triangles (the float BVH boxes only prune, conservatively), triangles are reported by
// their original mesh index, and degenerate (zero-area) triangles are never reported.
//
// All points are in the mesh's frame, in its units. Queries are pure, thread-safe,
// allocation-free and never throw. A NaN or infinite input gives an empty answer
// (a miss, nothing found, outside, no contacts) at once.

#include <limits>
#include <span>

#include "server/geometry/bvh.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SegmentMeshHit {
  bool hit = false;
  double t = 0;       // hit point = p + t (q - p), t in [0, 1]
  int triangle = -1;  // original index of a triangle containing the hit point
  double u = 0;       // barycentric coordinates of the hit on that triangle
  double v = 0;
};

// First point along p -> q where the closed segment touches the mesh. The hit/miss
// decision is exact per triangle (IntersectSegmentTriangleWatertight): a segment aimed
// through a vertex or edge shared by triangles of a closed mesh hits one of them, and a
// segment that only touches counts. A triangle whose plane contains the segment is not
// hit (its neighbours may be). Where several triangles hold the first point, any one
// is reported. Precondition: p != q; a zero-length segment returns a miss.
SegmentMeshHit FindFirstSegmentHit(const MeshBvh& bvh, const Vector3& p, const Vector3& q);

// True when the closed segment p -> q touches any triangle (occlusion test; stops at the
// first hit found). Same decisions and precondition as FindFirstSegmentHit.
bool SegmentHitsMesh(const MeshBvh& bvh, const Vector3& p, const Vector3& q);

struct MeshClosestPoint {
  bool found = false;
  int triangle = -1;  // original index of the triangle holding the closest point
  TriangleFeature feature = TriangleFeature::kFace;  // where on that triangle
  Vector3 point = Vector3::Zero();
  double u = 0;  // barycentric coordinates of point on that triangle
  double v = 0;
  double distance = 0;
};

// The point of the mesh closest to p, if one lies within max_distance (closed: at
// exactly max_distance counts, up to rounding of squared distances). max_distance may
// be infinite; negative or NaN finds nothing. Where several points tie, any one.
MeshClosestPoint FindClosestPointOnMesh(const MeshBvh& bvh, const Vector3& p,
                                        double max_distance =
                                            std::numeric_limits<double>::infinity());

struct SphereMeshContact {
  int triangle = -1;   // original index of the touched triangle
  Vector3 point = Vector3::Zero();   // the triangle's point closest to the centre
  // Unit, from the triangle towards the centre: on a face the face normal turned to
  // the centre's side (the face normal itself when the centre is on the face); on an
  // edge or vertex the gap's direction (the feature's pseudo-normal when the gap is
  // too small to give one).
  Vector3 normal = Vector3::Zero();
  double depth = 0;    // radius - distance from the centre to the triangle, >= 0
  TriangleFeature feature = TriangleFeature::kFace;
};

struct SphereMeshContacts {
  int count = 0;       // contacts written to the buffer
  int num_touching = 0;  // triangles the sphere touches, written or not
  bool truncated = false;  // num_touching > buffer size: the deepest ones were kept
};

// Every triangle within the closed sphere (touching counts, depth 0), one contact per
// triangle, written to `out` without allocating. When more triangles touch than `out`
// holds, the deepest out.size() are kept (in no particular order) and truncated is set.
// A negative or NaN radius touches nothing.
SphereMeshContacts FindSphereMeshContacts(const MeshBvh& bvh, const Sphere& sphere,
                                          std::span<SphereMeshContact> out);

// A closest point this close to p (relative to the coordinates' magnitude) may be
// rounding away from a point on the surface: the exact on-surface test decides.
inline constexpr double kOnSurfaceTolerance = 1e-10;

// Exactly whether p lies on the closed triangle: coplanar (Orient3d), then inside the
// triangle's projection onto a coordinate plane where the projection keeps its area.
bool IsPointOnTriangle(const Vector3& p, const Triangle& t);

// The sign rule of CalcSignedDistanceToMesh, before its flip for a mesh wound inwards:
// p is outside when it lies on the positive side of the closest feature's angle-
// weighted pseudo-normal (exactly, by Orient3d, when that feature is a face).
bool IsOutsideOfClosestFeature(const TriangleMesh& mesh, const Vector3& p, const MeshClosestPoint& closest);

struct MeshSignedDistance {
  bool inside = false;       // within the closed solid; on the surface counts
  double signed_distance = 0;  // -distance inside, +distance outside, 0 on the surface
  MeshClosestPoint closest;  // the closest surface point (found is always true on success)
};

// Signed distance and side of p for a closed mesh (TriangleMesh::is_closed()): the
// closest point, then the sign of (p - closest) against the angle-weighted
// pseudo-normal of the closest feature (Baerentzen & Aanaes 2005). A point exactly on
// a triangle is found by exact predicates and counts as inside. A closed mesh whose
// normals point inwards (negative signed volume) is treated as its outward twin. On an
// open mesh the sign is that of the nearest surface's pseudo-normal (meaningful only
// near it). Cost grows where many triangles are nearly equidistant (the centre of a
// sphere visits them all).
MeshSignedDistance CalcSignedDistanceToMesh(const MeshBvh& bvh, const Vector3& p);

// CalcSignedDistanceToMesh(bvh, p).inside.
bool IsPointInsideMesh(const MeshBvh& bvh, const Vector3& p);

}  // namespace hapticd::geometry
