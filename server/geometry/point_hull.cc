#include "server/geometry/point_hull.h"

#include <cmath>
#include <limits>

#include "server/geometry/gjk.h"
#include "server/geometry/work_meter.h"

namespace hapticd::geometry {

PointHullResult CalcPointHullDistance(const ConvexHull& hull, const Vector3& p) {
  PointHullResult result;
  if (!p.allFinite() || hull.dimension != 3) return result;
  const SphereSupport point_support(Sphere{p, 0});
  const HullSupport hull_support(hull);
  const GjkResult gjk = CalcGjkDistance(hull_support, point_support);
  // a gap so small (subnormal) that its direction cannot be normalised is the surface:
  // the faces below decide, with a unit normal
  if (!gjk.intersect && gjk.distance > 0 && std::abs(gjk.normal.squaredNorm() - 1) < 1e-6) {
    result.found = true;
    result.signed_distance = gjk.distance;
    result.point = gjk.point_a;
    result.normal = gjk.normal;
    return result;
  }
  // inside: every face is tried, a unit of work per eight (a spent budget: no answer)
  if (!WorkMeter::Charge((static_cast<int64_t>(hull.faces.size()) + 7) / 8)) return result;
  double best = -std::numeric_limits<double>::infinity();
  int best_face = -1;
  for (size_t f = 0; f < hull.faces.size(); ++f) {
    const Vector3& n = hull.face_normals[f];
    // a sliver face whose normal underflowed has no direction to push along
    if (!(std::abs(n.squaredNorm() - 1) < 1e-6)) continue;
    const double height = n.dot(p - hull.vertices[hull.faces[f][0]]);
    if (height > best) best = height, best_face = static_cast<int>(f);
  }
  if (best_face < 0) return result;
  result.found = true;
  result.signed_distance = std::min(best, 0.0);
  result.normal = hull.face_normals[best_face];
  result.point = p - result.signed_distance * result.normal;
  return result;
}

}  // namespace hapticd::geometry
