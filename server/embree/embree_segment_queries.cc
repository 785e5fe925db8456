#include "server/embree/embree_segment_queries.h"

#include <algorithm>

#include "server/embree/segment_callbacks.h"

namespace hapticd::embree {
namespace {

using geometry::SegmentMeshHit;
using geometry::Vector3;
using internal::SegmentQuery;
using internal::SegmentQueryContext;
using internal::SetRay;

// A packet's valid mask: Embree reads it with aligned vector loads, so it must be
// aligned like the packet itself (16, 32 or 64 bytes); a plain int[W] faults in the 8-
// and 16-wide kernels that Embree picks on AVX and AVX-512 machines.
template <int W>
struct alignas(sizeof(int) * W) ValidMask {
  int lanes[W] = {};
};

// Packet types and entry points by width.
template <int W>
struct Packet;
template <>
struct Packet<4> {
  using RayHit = RTCRayHit4;
  static void Intersect(const ValidMask<4>& valid, RTCScene scene, RTCIntersectContext* context,
                        RayHit* rays) {
    rtcIntersect4(valid.lanes, scene, context, rays);
  }
};
template <>
struct Packet<8> {
  using RayHit = RTCRayHit8;
  static void Intersect(const ValidMask<8>& valid, RTCScene scene, RTCIntersectContext* context,
                        RayHit* rays) {
    rtcIntersect8(valid.lanes, scene, context, rays);
  }
};
template <>
struct Packet<16> {
  using RayHit = RTCRayHit16;
  static void Intersect(const ValidMask<16>& valid, RTCScene scene, RTCIntersectContext* context,
                        RayHit* rays) {
    rtcIntersect16(valid.lanes, scene, context, rays);
  }
};

// The segment has no answer through Embree: non-finite or zero-length input misses.
bool IsBadSegment(const Vector3& p, const Vector3& q) {
  return !p.allFinite() || !q.allFinite() || p == q;
}

// Answers segments [first, first + count) of the packet call, count <= W.
template <int W>
void TraceChunk(const EmbreeMesh& mesh, std::span<const Vector3> p, std::span<const Vector3> q,
                std::span<SegmentMeshHit> out, size_t first, int count) {
  static_assert(alignof(ValidMask<W>) == alignof(typename Packet<W>::RayHit),
                "Embree wants the valid mask aligned like the packet");
  SegmentQuery queries[W];
  ValidMask<W> valid;
  typename Packet<W>::RayHit rays{};
  bool any = false;
  for (int i = 0; i < count; ++i) {
    const Vector3& a = p[first + i];
    const Vector3& b = q[first + i];
    // bad or untrusted lanes are answered here; the packet skips them
    if (IsBadSegment(a, b)) {
      out[first + i] = {};
      continue;
    }
    if (!mesh.IsTrustedSegment(a, b)) {
      out[first + i] = geometry::FindFirstSegmentHit(mesh.bvh(), a, b);
      continue;
    }
    queries[i].p = a;
    queries[i].q = b;
    SetRay(rays.ray, [i](auto& field) -> auto& { return field[i]; }, a, b, static_cast<unsigned>(i));
    rays.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    valid.lanes[i] = -1;
    any = true;
  }
  if (!any) return;
  // the probes of one avatar start close together and point alike: coherent
  SegmentQueryContext context;
  rtcInitIntersectContext(&context.embree);
  context.embree.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  context.queries = queries;
  Packet<W>::Intersect(valid, mesh.scene(), &context.embree, &rays);
  for (int i = 0; i < count; ++i) {
    if (valid.lanes[i] != 0) out[first + i] = queries[i].hit;
  }
}

}  // namespace

SegmentMeshHit FindFirstSegmentHit(const EmbreeMesh& mesh, const Vector3& p, const Vector3& q) {
  if (IsBadSegment(p, q)) return {};
  if (!mesh.IsTrustedSegment(p, q)) return geometry::FindFirstSegmentHit(mesh.bvh(), p, q);
  SegmentQuery query;
  query.p = p;
  query.q = q;
  SegmentQueryContext context;
  rtcInitIntersectContext(&context.embree);
  context.queries = &query;
  RTCRayHit ray{};
  SetRay(ray.ray, [](auto& field) -> auto& { return field; }, p, q, 0);
  ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(mesh.scene(), &context.embree, &ray);
  return query.hit;
}

bool SegmentHitsMesh(const EmbreeMesh& mesh, const Vector3& p, const Vector3& q) {
  if (IsBadSegment(p, q)) return false;
  if (!mesh.IsTrustedSegment(p, q)) return geometry::SegmentHitsMesh(mesh.bvh(), p, q);
  SegmentQuery query;
  query.p = p;
  query.q = q;
  SegmentQueryContext context;
  rtcInitIntersectContext(&context.embree);
  context.queries = &query;
  RTCRay ray{};
  SetRay(ray, [](auto& field) -> auto& { return field; }, p, q, 0);
  rtcOccluded1(mesh.scene(), &context.embree, &ray);
  return query.touched;
}

void FindFirstSegmentHits(const EmbreeMesh& mesh, std::span<const Vector3> p,
                          std::span<const Vector3> q, std::span<SegmentMeshHit> out) {
  const size_t n = std::min({p.size(), q.size(), out.size()});
  // chunks of 16, the last one in the narrowest packet that holds it
  for (size_t first = 0; first < n; first += 16) {
    const int count = static_cast<int>(std::min<size_t>(16, n - first));
    if (count <= 4) {
      TraceChunk<4>(mesh, p, q, out, first, count);
    } else if (count <= 8) {
      TraceChunk<8>(mesh, p, q, out, first, count);
    } else {
      TraceChunk<16>(mesh, p, q, out, first, count);
    }
  }
}

}  // namespace hapticd::embree
