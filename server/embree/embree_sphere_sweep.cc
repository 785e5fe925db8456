#include "server/embree/embree_sphere_sweep.h"

#include <cmath>

#include "server/embree/segment_callbacks.h"
#include "server/embree/work_budget_callbacks.h"
#include "server/geometry/aabb.h"

namespace hapticd::embree {
namespace {

using geometry::Aabb;
using geometry::SphereSweepHit;
using geometry::Vector3;

// What the point query callback reads and improves.
struct SphereSweepSearch {
  const EmbreeMesh* mesh = nullptr;
  Vector3 a = Vector3::Zero();
  Vector3 b = Vector3::Zero();
  double r = 0;
  Aabb reach;  // the sweep's box grown by what it can reach: the native's exact reject
  SphereSweepHit hit;
};

// The per-triangle sweep on one candidate; the first contact is kept (a tie keeps the
// one found first, as the native sweep does). The ball never shrinks: a shorter motion
// still starts at a, which lies on its rim.
bool SweepCandidate(RTCPointQueryFunctionArguments* args) {
  if (internal::ShrinkWhenOverBudget(args)) return true;
  auto& search = *static_cast<SphereSweepSearch*>(args->userPtr);
  const geometry::Triangle& triangle = search.mesh->primitive(args->primID);
  if (!geometry::AabbsOverlap(search.reach, Aabb::OfTriangle(triangle))) return false;
  SphereSweepHit h = geometry::SweepSphereTriangle(triangle, search.a, search.b, search.r);
  if (!h.hit || (search.hit.hit && !(h.t < search.hit.t))) return false;
  h.triangle = search.mesh->primitive_triangle(args->primID);
  search.hit = h;
  return false;
}

}  // namespace

SphereSweepHit SweepPointMesh(const EmbreeMesh& mesh, const Vector3& a, const Vector3& b) {
  // non-finite input, or no motion: a miss, as natively
  if (!a.allFinite() || !b.allFinite() || a == b) return {};
  // beyond the trust bound Embree could skip a triangle: the native BVH answers
  if (!mesh.IsTrustedSegment(a, b)) return geometry::SweepSphereMesh(mesh.bvh(), a, b, 0);
  // one ray; the intersect callback sweeps each candidate exactly and cuts the ray
  internal::PointSweepQuery sweep;
  sweep.a = a;
  sweep.b = b;
  internal::SegmentQueryContext context;
  rtcInitIntersectContext(&context.embree);
  context.sweeps = &sweep;
  RTCRayHit ray{};
  internal::SetRay(ray.ray, [](auto& field) -> auto& { return field; }, a, b, 0);
  ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(mesh.scene(), &context.embree, &ray);
  return sweep.hit;
}

SphereSweepHit SweepSphereMesh(const EmbreeMesh& mesh, const Vector3& a, const Vector3& b, double r) {
  // the native misses at once: NaN, infinite, no motion, r < 0
  if (!a.allFinite() || !b.allFinite() || a == b || !(r >= 0) || !std::isfinite(r)) return {};
  if (r == 0) return SweepPointMesh(mesh, a, b);
  if (!mesh.IsTrustedSegment(a, b) || !(r <= mesh.trust_bound())) {
    return geometry::SweepSphereMesh(mesh.bvh(), a, b, r);
  }
  SphereSweepSearch search;
  search.mesh = &mesh;
  search.a = a;
  search.b = b;
  search.r = r;
  // what the native sweep can reach, and prunes beyond
  const double reach = geometry::CalcSphereSweepReach(a, b, r);
  search.reach = Aabb{a.cwiseMin(b), a.cwiseMax(b)}.Inflated(reach);
  // the ball around the motion's middle that holds the swept capsule; the centre's
  // rounding to float is far inside the guard
  const Vector3 middle = 0.5 * (a + b);
  alignas(16) RTCPointQuery query{};
  query.x = static_cast<float>(middle.x());
  query.y = static_cast<float>(middle.y());
  query.z = static_cast<float>(middle.z());
  query.time = 0.0f;
  query.radius = RoundUp(0.5 * (b - a).norm() + reach + mesh.guard());
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(mesh.scene(), &query, &context, &SweepCandidate, &search);
  return search.hit;
}

}  // namespace hapticd::embree
