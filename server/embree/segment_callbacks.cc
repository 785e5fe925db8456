#include "server/embree/segment_callbacks.h"

#include <limits>

#include "server/embree/embree_mesh.h"
#include "server/embree/work_budget_callbacks.h"
#include "server/geometry/aabb.h"
#include "server/geometry/segment_triangle.h"

namespace hapticd::embree::internal {
namespace {

using geometry::Aabb;
using geometry::TriangleHit;

// The exact decision on one candidate, as the native query makes it: the watertight
// test. No box test first: Embree hands over only primitives whose guarded box the ray
// entered, and the segment's box missed the triangle's in 5 of 27,915 candidates on the
// speed-accuracy inputs, less than the test costs on every candidate.
TriangleHit TestCandidate(const SegmentQuery& query, const geometry::Triangle& triangle) {
  return geometry::IntersectSegmentTriangleWatertight(query.p, query.q, triangle);
}

SegmentQueryContext& ContextOf(RTCIntersectContext* context) {
  return *reinterpret_cast<SegmentQueryContext*>(context);
}

// Records lane i's new first hit, at t on the candidate, in Embree's hit and cuts the
// ray no closer than t: boxes before it stay in reach.
void CutRay(const RTCIntersectFunctionNArguments* args, unsigned i, double t, double u,
            double v) {
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* hits = RTCRayHitN_HitN(args->rayhit, args->N);
  RTCRayN_tfar(rays, args->N, i) = RoundUp(t);
  RTCHitN_u(hits, args->N, i) = static_cast<float>(u);
  RTCHitN_v(hits, args->N, i) = static_cast<float>(v);
  RTCHitN_primID(hits, args->N, i) = args->primID;
  RTCHitN_geomID(hits, args->N, i) = args->geomID;
  RTCHitN_instID(hits, args->N, i, 0) = args->context->instID[0];
}

// The point sweeps' decision on one candidate, as geometry::SweepSphereMesh makes it for
// r = 0: the per-triangle sweep, the first blocking contact kept.
void SweepCandidate(const RTCIntersectFunctionNArguments* args, const EmbreeMesh& mesh,
                    PointSweepQuery* sweeps) {
  const geometry::Triangle& triangle = mesh.primitive(args->primID);
  const Aabb triangle_box = Aabb::OfTriangle(triangle);
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    PointSweepQuery& query = sweeps[RTCRayN_id(rays, args->N, i)];
    // boxes apart (exact comparisons): the segment cannot touch the triangle
    const Aabb sweep_box{query.a.cwiseMin(query.b), query.a.cwiseMax(query.b)};
    if (!geometry::AabbsOverlap(sweep_box, triangle_box)) continue;
    geometry::SphereSweepHit h = geometry::SweepSphereTriangle(triangle, query.a, query.b, 0);
    // keep the first contact; a tie keeps the one found first, as the native sweep does
    if (!h.hit || (query.hit.hit && !(h.t < query.hit.t))) continue;
    h.triangle = mesh.primitive_triangle(args->primID);
    query.hit = h;
    CutRay(args, i, h.t, 0, 0);
  }
}

}  // namespace

void IntersectCandidate(const RTCIntersectFunctionNArguments* args) {
  const auto& mesh = *static_cast<const EmbreeMesh*>(args->geometryUserPtr);
  SegmentQueryContext& context = ContextOf(args->context);
  if (EndWhenOverBudget(RTCRayHitN_RayN(args->rayhit, args->N), args->N, args->valid)) return;
  // point sweeps decide by the god-object's rules
  if (context.sweeps != nullptr) {
    SweepCandidate(args, mesh, context.sweeps);
    return;
  }
  const geometry::Triangle& triangle = mesh.primitive(args->primID);
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    SegmentQuery& query = context.queries[RTCRayN_id(rays, args->N, i)];
    const TriangleHit h = TestCandidate(query, triangle);
    // keep the first hit; a tie keeps the one found first, as the native query does
    if (!h.hit || (query.hit.hit && !(h.t < query.hit.t))) continue;
    query.hit = {true, h.t, mesh.primitive_triangle(args->primID), h.u, h.v};
    CutRay(args, i, h.t, h.u, h.v);
  }
}

void OccludeCandidate(const RTCOccludedFunctionNArguments* args) {
  const auto& mesh = *static_cast<const EmbreeMesh*>(args->geometryUserPtr);
  SegmentQueryContext& context = ContextOf(args->context);
  if (EndWhenOverBudget(args->ray, args->N, args->valid)) return;
  const geometry::Triangle& triangle = mesh.primitive(args->primID);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    SegmentQuery& query = context.queries[RTCRayN_id(args->ray, args->N, i)];
    if (!TestCandidate(query, triangle).hit) continue;
    query.touched = true;
    RTCRayN_tfar(args->ray, args->N, i) = -std::numeric_limits<float>::infinity();
  }
}

}  // namespace hapticd::embree::internal
