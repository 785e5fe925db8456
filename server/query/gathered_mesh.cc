#include "server/query/gathered_mesh.h"

#include <cmath>

#include "server/geometry/aabb.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/work_meter.h"

namespace hapticd::query {
namespace {

// How far from p the gathered triangles hold everything: what lies farther may belong to
// triangles left out. Negative (or NaN) when nothing is known there.
double KnownReach(const GatheredMesh& near, const Vector3& p) {
  const geometry::Capsule& region = near.region_B;
  return region.radius - geometry::CalcPointSegmentDistance(p, region.p0, region.p1) - kGatheredSlack;
}

// Whether the triangle lies farther from p than limit by more than the bound's rounding
// could hide and the exact test's could reveal: so far (1e-12 of the coordinates'
// magnitude, a hundred times their rounding) that passing it over never changes an answer,
// ties included.
bool PassedOver(const geometry::PreparedTriangle& t, const Vector3& p, double p_scale, double limit) {
  const double slack = 1e-12 * (p_scale + t.centroid.cwiseAbs().maxCoeff() + t.bounding_radius);
  return geometry::LiesFartherThan(t, p, limit + slack);
}

}  // namespace

std::optional<geometry::MeshClosestPoint> FindGatheredClosestPoint(const GatheredMesh& near, const Vector3& p_B,
                                                                   double max_distance) {
  const double known = KnownReach(near, p_B);
  if (!(known >= 0) || !(max_distance >= 0)) return std::nullopt;
  const std::span<const geometry::PreparedTriangle> triangles = near.triangles;
  const int n = static_cast<int>(triangles.size());
  if (!geometry::WorkMeter::Charge((2 * static_cast<int64_t>(n) + 7) / 8)) return std::nullopt;
  // FindClosestPointOnMesh's rule: within max_distance, then strictly nearer; here of
  // equally near triangles the first in the span, whichever is tried first. The one
  // with the nearest box is tried first, so that the others are mostly passed over by
  // their boxes or their planes.
  double best_d2 = max_distance * max_distance;
  int seed = -1;
  double seed_d2 = best_d2;
  // the boxes' distances, kept for the second pass (as many as fit)
  constexpr int kKeptBoxDistances = 256;
  double box_d2[kKeptBoxDistances];
  const auto box_distance_squared = [&](int i) {
    return i < kKeptBoxDistances ? box_d2[i] : geometry::CalcPointAabbDistanceSquared(p_B, triangles[i].box);
  };
  for (int i = 0; i < n; ++i) {
    const double d2 = geometry::CalcPointAabbDistanceSquared(p_B, triangles[i].box);
    if (i < kKeptBoxDistances) box_d2[i] = d2;
    if (d2 <= seed_d2 && (seed < 0 || d2 < seed_d2)) seed = i, seed_d2 = d2;
  }
  int best = -1;
  geometry::ClosestPointOnTriangle best_point;
  double limit = max_distance;  // sqrt(best_d2): what a triangle must lie beyond to be passed over
  const double p_scale = p_B.cwiseAbs().maxCoeff();
  const auto consider = [&](int i) {
    const geometry::ClosestPointOnTriangle c = geometry::FindClosestPointOnTriangle(p_B, triangles[i].triangle);
    if (!(c.distance_squared <= best_d2)) return;
    if (best >= 0 && c.distance_squared == best_d2 && i > best) return;
    best = i;
    best_d2 = c.distance_squared;
    best_point = c;
    limit = std::sqrt(best_d2);
  };
  if (seed >= 0) {
    if (!geometry::WorkMeter::Charge(1)) return std::nullopt;
    consider(seed);
    for (int i = 0; i < n; ++i) {
      if (i == seed || box_distance_squared(i) > best_d2 ||
          PassedOver(triangles[i], p_B, p_scale, limit)) {
        continue;
      }
      if (!geometry::WorkMeter::Charge(1)) return std::nullopt;
      consider(i);
    }
  }
  geometry::MeshClosestPoint closest;
  if (best < 0) {
    // nothing gathered within max_distance: the mesh has nothing there either when the
    // gathered ball holds all of it
    if (max_distance <= known) return closest;
    return std::nullopt;
  }
  closest = {true, triangles[best].index, best_point.feature, best_point.point, best_point.u, best_point.v,
             std::sqrt(best_d2)};
  if (!(closest.distance <= known)) return std::nullopt;
  return closest;
}

std::optional<geometry::SphereSweepHit> SweepGatheredSphere(const GatheredMesh& near, const Vector3& a_B,
                                                            const Vector3& b_B, double r) {
  // what SweepSphereMesh misses at once
  if (!a_B.allFinite() || !b_B.allFinite() || !(r >= 0) || !std::isfinite(r) || a_B == b_B) {
    return geometry::SphereSweepHit{};
  }
  // the centre must stay this near the gathered segment until the first contact: then
  // every triangle it comes within reach of was gathered (the region is convex, so its
  // two ends are enough)
  const double reach = geometry::CalcSphereSweepReach(a_B, b_B, r);
  if (!(KnownReach(near, a_B) >= reach)) return std::nullopt;
  const geometry::SphereSweepHit hit = geometry::SweepSphereTriangles(near.triangles, a_B, b_B, r);
  const Vector3 last = hit.hit ? Vector3(a_B + hit.t * (b_B - a_B)) : b_B;
  if (!(KnownReach(near, last) >= reach)) return std::nullopt;
  return hit;
}

}  // namespace hapticd::query
