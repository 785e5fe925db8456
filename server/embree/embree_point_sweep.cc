#include "server/embree/embree_point_sweep.h"

#include "server/embree/segment_callbacks.h"

namespace hapticd::embree {

using geometry::SphereSweepHit;
using geometry::Vector3;

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

}  // namespace hapticd::embree
