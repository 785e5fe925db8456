#pragma once

// Internal: what Embree calls back for each candidate primitive of an EmbreeMesh during
// a segment query, and the context those callbacks read. A query lays out one entry
// per ray of its packet (a single ray is a packet of one) and gives each ray its entry
// index as its Embree ray id; the callbacks never assume a packet width. A context
// holds either segment queries (the watertight test decides) or point sweeps (the
// god-object's r = 0 sweep rules decide); the intersect callback serves both.

#include <embree3/rtcore.h>

#include "server/geometry/mesh_queries.h"
#include "server/geometry/sphere_sweep.h"
#include "server/geometry/types.h"

namespace hapticd::embree::internal {

// The double-precision segment behind an Embree ray, and its answer so far.
struct SegmentQuery {
  geometry::Vector3 p = geometry::Vector3::Zero();
  geometry::Vector3 q = geometry::Vector3::Zero();
  geometry::SegmentMeshHit hit;  // first exact hit found (intersect queries)
  bool touched = false;          // any exact hit found (occlusion queries)
};

// The double-precision point sweep a -> b (r = 0) behind an Embree ray, and its first
// blocking contact so far (triangle: the original mesh index).
struct PointSweepQuery {
  geometry::Vector3 a = geometry::Vector3::Zero();
  geometry::Vector3 b = geometry::Vector3::Zero();
  geometry::SphereSweepHit hit;
};

// Embree passes &embree back to the callbacks; it must stay the first member, so that
// the callbacks can recover the whole context from it (standard layout).
struct SegmentQueryContext {
  RTCIntersectContext embree;
  SegmentQuery* queries = nullptr;  // indexed by ray id
  // Set instead of queries for point sweeps (indexed by ray id); occlusion queries
  // never use it.
  PointSweepQuery* sweeps = nullptr;
};

// The float ray of the segment p -> q: org = p, dir = q - p, t in [0, 1], labelled
// with the index of its query (SegmentQuery or PointSweepQuery). Works for RTCRay and,
// through lane(field) -> field[i], each lane of RTCRayN.
template <typename Ray, typename Lane>
void SetRay(Ray& ray, Lane lane, const geometry::Vector3& p, const geometry::Vector3& q,
            unsigned id) {
  const geometry::Vector3 d = q - p;
  lane(ray.org_x) = static_cast<float>(p.x());
  lane(ray.org_y) = static_cast<float>(p.y());
  lane(ray.org_z) = static_cast<float>(p.z());
  lane(ray.dir_x) = static_cast<float>(d.x());
  lane(ray.dir_y) = static_cast<float>(d.y());
  lane(ray.dir_z) = static_cast<float>(d.z());
  lane(ray.tnear) = 0.0f;
  lane(ray.tfar) = 1.0f;
  lane(ray.time) = 0.0f;
  lane(ray.mask) = ~0u;
  lane(ray.id) = id;
  lane(ray.flags) = 0u;
}

// Intersect callback of the EmbreeMesh user geometry: the exact watertight test of each
// active ray's segment against the primitive (or, for point sweeps, the per-triangle
// sweep geometry::SweepSphereTriangle with r = 0); a better (smaller t) hit is recorded
// and cuts the ray at t rounded up to float, so Embree still visits every box the
// segment could touch before it.
void IntersectCandidate(const RTCIntersectFunctionNArguments* args);

// Occluded callback: the exact test; a hit is recorded and ends that ray (tfar = -inf,
// Embree's convention for "occluded").
void OccludeCandidate(const RTCOccludedFunctionNArguments* args);

}  // namespace hapticd::embree::internal
