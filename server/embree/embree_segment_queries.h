#pragma once

// Segment queries of an EmbreeMesh: first hit (rtcIntersect1), occlusion
// (rtcOccluded1) and packets of first hits (rtcIntersect4/8/16). Same result types and
// semantics as the native queries in server/geometry/mesh_queries.h, and the same
// answers: Embree's traversal picks the candidate triangles (a superset of those the
// segment touches, see embree_mesh.h), the exact watertight test decides on each.
//
// Points are in the mesh's frame. Thread-safe, allocation-free, never throw. NaN or
// infinite input, or p == q, gives a miss at once, as natively; a segment beyond the
// mesh's trust bound is answered by the native BVH.

#include <span>

#include "server/embree/embree_mesh.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

// First point along p -> q where the closed segment touches the mesh; touching counts,
// a segment through a shared vertex or edge of a closed mesh hits, a triangle whose
// plane holds the segment is not hit. Equals geometry::FindFirstSegmentHit (where two
// triangles hold the first point at the same t, either may be reported).
geometry::SegmentMeshHit FindFirstSegmentHit(const EmbreeMesh& mesh, const geometry::Vector3& p,
                                             const geometry::Vector3& q);

// True when the closed segment p -> q touches the mesh. Equals geometry::SegmentHitsMesh.
bool SegmentHitsMesh(const EmbreeMesh& mesh, const geometry::Vector3& p,
                     const geometry::Vector3& q);

// out[i] = FindFirstSegmentHit(mesh, p[i], q[i]) for the first min(p, q, out sizes)
// segments, traced together as coherent Embree packets of up to 16 rays (a sphere
// avatar's probes, a tool's points). Bad or untrusted segments in a packet are answered
// on their own, as above, without disturbing the others.
void FindFirstSegmentHits(const EmbreeMesh& mesh, std::span<const geometry::Vector3> p,
                          std::span<const geometry::Vector3> q,
                          std::span<geometry::SegmentMeshHit> out);

}  // namespace hapticd::embree
