#include "server/geometry/closest_point_triangle.h"

#include <algorithm>
#include <limits>

#include "server/geometry/point_segment.h"

namespace hapticd::geometry {
namespace {

// Below this squared sine of the angle between ab and ac, the barycentric region tests
// cannot be trusted (their terms cancel to rounding noise).
constexpr double kSliverSine2 = 1e-8;

// A zero-area triangle: the best of its three edges.
ClosestPointOnTriangle ClosestOnDegenerate(const Vector3& p, const Triangle& tri) {
  ClosestPointOnTriangle best;
  best.distance_squared = std::numeric_limits<double>::infinity();
  const Vector3* corners[3] = {&tri.v0, &tri.v1, &tri.v2};
  static constexpr TriangleFeature kEdges[3] = {TriangleFeature::kEdge01, TriangleFeature::kEdge12,
                                                TriangleFeature::kEdge20};
  for (int i = 0; i < 3; ++i) {
    const Vector3& a = *corners[i];
    const Vector3& b = *corners[(i + 1) % 3];
    const double s = ClosestParameterOnSegment(p, a, b);
    const Vector3 x = a + s * (b - a);
    const double d2 = (p - x).squaredNorm();
    if (d2 < best.distance_squared) {
      // barycentric weights: 1 - s on corner i, s on corner i + 1
      double w[3] = {0, 0, 0};
      w[i] = 1 - s;
      w[(i + 1) % 3] = s;
      best = {x, w[1], w[2], kEdges[i], d2};
    }
  }
  return best;
}

ClosestPointOnTriangle Make(const Vector3& p, const Vector3& x, double u, double v,
                            TriangleFeature feature) {
  return {x, u, v, feature, (p - x).squaredNorm()};
}

}  // namespace

ClosestPointOnTriangle FindClosestPointOnTriangle(const Vector3& p, const Triangle& tri) {
  if (!(p.allFinite() && tri.v0.allFinite() && tri.v1.allFinite() && tri.v2.allFinite())) {
    constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
    return {Vector3::Constant(kNan), kNan, kNan, TriangleFeature::kFace, kNan};
  }
  // Ericson's Voronoi-region walk: test the vertex regions, then the edge regions;
  // what remains is the face. d1..d6 are the projections of p onto the two edges
  // from each vertex; va, vb, vc are the (scaled) barycentrics.
  const Vector3& a = tri.v0;
  const Vector3& b = tri.v1;
  const Vector3& c = tri.v2;
  const Vector3 ab = b - a;
  const Vector3 ac = c - a;
  const Vector3 ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  // vertex region of a
  if (d1 <= 0 && d2 <= 0) return Make(p, a, 0, 0, TriangleFeature::kVertex0);

  const Vector3 bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  // vertex region of b
  if (d3 >= 0 && d4 <= d3) return Make(p, b, 1, 0, TriangleFeature::kVertex1);

  // edge region of ab
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double s = d1 / (d1 - d3);
    return Make(p, a + s * ab, s, 0, TriangleFeature::kEdge01);
  }

  const Vector3 cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  // vertex region of c
  if (d6 >= 0 && d5 <= d6) return Make(p, c, 0, 1, TriangleFeature::kVertex2);

  // edge region of ac
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double s = d2 / (d2 - d6);
    return Make(p, a + s * ac, 0, s, TriangleFeature::kEdge20);
  }

  // edge region of bc
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return Make(p, b + s * (c - b), 1 - s, s, TriangleFeature::kEdge12);
  }

  // face region; a zero-area triangle has no face and ends up here with denom <= 0
  const double denom = va + vb + vc;
  if (!(denom > 0)) return ClosestOnDegenerate(p, tri);
  const double v = vb / denom;
  const double w = vc / denom;
  const ClosestPointOnTriangle face = Make(p, a + v * ab + w * ac, v, w, TriangleFeature::kFace);
  // A sliver (sin^2 of the angle at a below kSliverSine2): va, vb, vc are mostly
  // rounding noise, so the region walk may land here wrongly. The edges then hold the
  // answer to within the sliver's width; keep the face point only where it is closer
  // and truly inside.
  if (denom > kSliverSine2 * ab.squaredNorm() * ac.squaredNorm()) return face;
  const ClosestPointOnTriangle edges = ClosestOnDegenerate(p, tri);
  const bool face_inside = v >= 0 && w >= 0 && v + w <= 1;
  return face_inside && face.distance_squared < edges.distance_squared ? face : edges;
}

}  // namespace hapticd::geometry
