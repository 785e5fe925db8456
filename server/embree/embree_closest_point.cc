#include "server/embree/embree_closest_point.h"

#include <cmath>

#include "server/embree/work_budget_callbacks.h"
#include "server/geometry/closest_point_triangle.h"

namespace hapticd::embree {
namespace {

using geometry::MeshClosestPoint;
using geometry::Triangle;
using geometry::Vector3;

// What the point query callback reads and improves.
struct ClosestPointSearch {
  const EmbreeMesh* mesh = nullptr;
  Vector3 p = Vector3::Zero();
  double best_d2 = 0;  // squared search radius: max_distance^2, then the best so far
  MeshClosestPoint best;
  // when set, judged on the best and on its exact ties
  internal::SideOfCandidate side = nullptr;
  bool best_outside = false;
  bool sides_differ = false;
};

// Squared distance from p to the box around t: a cheap lower bound of the distance to
// t (Embree calls back for every primitive of a leaf it reaches, near or not).
double BoxDistanceSquared(const Vector3& p, const Triangle& t) {
  const Vector3 lo = t.v0.cwiseMin(t.v1).cwiseMin(t.v2);
  const Vector3 hi = t.v0.cwiseMax(t.v1).cwiseMax(t.v2);
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm();
}

// The radius Embree searches for a distance: rounded up and grown by the guard, so
// that every triangle as close stays in reach (Embree's tests may be strict, and a
// radius of zero would find nothing).
float EmbreeRadius(const EmbreeMesh& mesh, double distance) {
  return RoundUp(distance + mesh.guard());
}

// The exact closest point on one candidate; a better one shrinks Embree's radius.
bool VisitCandidate(RTCPointQueryFunctionArguments* args) {
  if (internal::ShrinkWhenOverBudget(args)) return true;
  auto& search = *static_cast<ClosestPointSearch*>(args->userPtr);
  const Triangle& triangle = search.mesh->primitive(args->primID);
  if (BoxDistanceSquared(search.p, triangle) > search.best_d2) return false;
  const geometry::ClosestPointOnTriangle c =
      geometry::FindClosestPointOnTriangle(search.p, triangle);
  const MeshClosestPoint candidate{true, search.mesh->primitive_triangle(args->primID),
                                   c.feature, c.point, c.u, c.v, 0};
  // an exact tie of the best: its side may differ (only when sides are asked for)
  if (search.side != nullptr && search.best.found && c.distance_squared == search.best_d2) {
    if (search.side(search.mesh->mesh(), search.p, candidate) != search.best_outside) {
      search.sides_differ = true;
    }
    return false;
  }
  // within the radius at first, then strictly closer (the native rule)
  const bool closer = c.distance_squared < search.best_d2 ||
                      (!search.best.found && c.distance_squared <= search.best_d2);
  if (!closer) return false;
  search.best_d2 = c.distance_squared;
  search.best = candidate;
  // a new best: the ties of the old one no longer matter
  if (search.side != nullptr) {
    search.best_outside = search.side(search.mesh->mesh(), search.p, candidate);
    search.sides_differ = false;
  }
  const float radius = EmbreeRadius(*search.mesh, std::sqrt(c.distance_squared));
  if (!(radius < args->query->radius)) return false;
  args->query->radius = radius;
  return true;
}

// Runs the search through Embree. Precondition: p trusted, max_distance >= 0.
void Search(const EmbreeMesh& mesh, double max_distance, ClosestPointSearch& search) {
  search.mesh = &mesh;
  search.best_d2 = max_distance * max_distance;
  alignas(16) RTCPointQuery query{};
  query.x = static_cast<float>(search.p.x());
  query.y = static_cast<float>(search.p.y());
  query.z = static_cast<float>(search.p.z());
  query.time = 0.0f;
  query.radius = EmbreeRadius(mesh, max_distance);
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(mesh.scene(), &query, &context, &VisitCandidate, &search);
  if (search.best.found) search.best.distance = std::sqrt(search.best_d2);
}

}  // namespace

MeshClosestPoint FindClosestPointOnMesh(const EmbreeMesh& mesh, const Vector3& p,
                                        double max_distance) {
  if (!p.allFinite() || !(max_distance >= 0)) return {};
  if (!mesh.IsTrustedPoint(p)) return geometry::FindClosestPointOnMesh(mesh.bvh(), p, max_distance);
  ClosestPointSearch search;
  search.p = p;
  Search(mesh, max_distance, search);
  return search.best;
}

namespace internal {

ClosestPointSides FindClosestPointAndSides(const EmbreeMesh& mesh, const Vector3& p,
                                           SideOfCandidate side) {
  ClosestPointSearch search;
  search.p = p;
  search.side = side;
  Search(mesh, std::numeric_limits<double>::infinity(), search);
  return {search.best, search.sides_differ};
}

}  // namespace internal
}  // namespace hapticd::embree
