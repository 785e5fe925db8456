#include "server/embree/embree_signed_distance.h"

#include "server/embree/embree_closest_point.h"
#include "server/embree/work_budget_callbacks.h"
#include "server/geometry/aabb.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"

namespace hapticd::embree {
namespace {

using geometry::Aabb;
using geometry::MeshSignedDistance;
using geometry::Triangle;
using geometry::TriangleFeature;
using geometry::Vector3;

// What the holder search's callback reads and fills.
struct HolderSearch {
  const EmbreeMesh* mesh = nullptr;
  Vector3 p = Vector3::Zero();
  int holder = -1;  // original index of a triangle holding p exactly
};

// Tests one candidate exactly; the radius never changes.
bool VisitHolderCandidate(RTCPointQueryFunctionArguments* args) {
  if (internal::ShrinkWhenOverBudget(args)) return true;
  auto& search = *static_cast<HolderSearch*>(args->userPtr);
  // one holder is enough
  if (search.holder >= 0) return false;
  const Triangle& triangle = search.mesh->primitive(args->primID);
  if (Aabb::OfTriangle(triangle).Contains(search.p) && geometry::IsPointOnTriangle(search.p, triangle)) {
    search.holder = search.mesh->primitive_triangle(args->primID);
  }
  return false;
}

// Original index of a triangle that holds p exactly, or -1. Every triangle holding p has
// a grown box within the guard of p rounded to float, so Embree hands it over.
// Precondition: mesh.IsTrustedPoint(p).
int FindTriangleHoldingPoint(const EmbreeMesh& mesh, const Vector3& p) {
  HolderSearch search;
  search.mesh = &mesh;
  search.p = p;
  alignas(16) RTCPointQuery query{};
  query.x = static_cast<float>(p.x());
  query.y = static_cast<float>(p.y());
  query.z = static_cast<float>(p.z());
  query.time = 0.0f;
  query.radius = RoundUp(mesh.guard());
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(mesh.scene(), &query, &context, &VisitHolderCandidate, &search);
  return search.holder;
}

}  // namespace

MeshSignedDistance CalcSignedDistanceToMesh(const EmbreeMesh& mesh, const Vector3& p) {
  // non-finite or beyond the trust bound: the native query answers (empty for NaN)
  if (!mesh.IsTrustedPoint(p)) return geometry::CalcSignedDistanceToMesh(mesh.bvh(), p);
  MeshSignedDistance result;
  const internal::ClosestPointSides found =
      internal::FindClosestPointAndSides(mesh, p, &geometry::IsOutsideOfClosestFeature);
  result.closest = found.closest;
  if (!result.closest.found) return result;
  geometry::MeshClosestPoint& closest = result.closest;
  const geometry::TriangleMesh& triangles = mesh.mesh();

  // on the surface: exactly zero, or found exactly when rounding leaves a tiny gap
  const double magnitude = triangles.size() + p.cwiseAbs().maxCoeff();
  if (closest.distance == 0) {
    result.inside = true;
    return result;
  }
  if (closest.distance <= geometry::kOnSurfaceTolerance * magnitude) {
    const int holder = FindTriangleHoldingPoint(mesh, p);
    if (holder >= 0) {
      const geometry::ClosestPointOnTriangle on =
          geometry::FindClosestPointOnTriangle(p, triangles.triangle(holder));
      closest = {true, holder, on.feature, p, on.u, on.v, 0};
      result.inside = true;
      return result;
    }
  }

  // closest features exactly as close on both sides (p within rounding of the surface,
  // or on a medial axis): the side is the native query's pick among them
  if (found.sides_differ) return geometry::CalcSignedDistanceToMesh(mesh.bvh(), p);
  // the side of the closest feature's pseudo-normal
  bool outside = geometry::IsOutsideOfClosestFeature(triangles, p, closest);
  // a closed mesh wound inwards: its outside is the other side
  if (triangles.signed_volume() < 0) outside = !outside;
  result.inside = !outside;
  result.signed_distance = outside ? closest.distance : -closest.distance;
  return result;
}

bool IsPointInsideMesh(const EmbreeMesh& mesh, const Vector3& p) {
  return CalcSignedDistanceToMesh(mesh, p).inside;
}

}  // namespace hapticd::embree
