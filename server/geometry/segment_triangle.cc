#include "server/geometry/segment_triangle.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

// Möller-Trumbore along origin + t dir, t in [0, t_max].
TriangleHit MollerTrumbore(const Vector3& origin, const Vector3& dir, const Triangle& tri,
                           double t_max) {
  const Vector3 e1 = tri.v1 - tri.v0;
  const Vector3 e2 = tri.v2 - tri.v0;
  const Vector3 pvec = dir.cross(e2);
  const double det = e1.dot(pvec);
  // parallel to the plane (or in it): a miss by convention
  if (det == 0) return {};
  const double inv_det = 1.0 / det;
  const Vector3 tvec = origin - tri.v0;
  const double u = tvec.dot(pvec) * inv_det;
  if (!(u >= 0 && u <= 1)) return {};
  const Vector3 qvec = tvec.cross(e1);
  const double v = dir.dot(qvec) * inv_det;
  if (!(v >= 0 && u + v <= 1)) return {};
  const double t = e2.dot(qvec) * inv_det;
  if (!(t >= 0 && t <= t_max)) return {};
  return {true, t, u, v};
}

// Barycentrics of the point where the line crosses the triangle, from the line's
// signed volumes against the three directed edges (each weight is the volume of the
// edge opposite its vertex). An exactly-zero sign pins that weight to zero, so a
// touching edge or vertex reports u, v exactly on the boundary.
void SetBarycentrics(const Vector3& o, const Vector3& dir, const Triangle& tri, int sign_01,
                     int sign_12, int sign_20, TriangleHit& hit) {
  const auto volume = [&](const Vector3& a, const Vector3& b, int sign) {
    return sign == 0 ? 0.0 : dir.dot((a - o).cross(b - o));
  };
  const double w0 = volume(tri.v1, tri.v2, sign_12);
  const double w1 = volume(tri.v2, tri.v0, sign_20);
  const double w2 = volume(tri.v0, tri.v1, sign_01);
  const double sum = w0 + w1 + w2;
  // the rounded volumes can all vanish (or overflow) where the exact signs do not: then
  // no corner is known to be nearer, and the centroid stands for the hit
  if (!(std::abs(sum) > 0) || !std::isfinite(sum)) {
    hit.u = hit.v = 1.0 / 3;
    return;
  }
  hit.u = std::clamp(w1 / sum, 0.0, 1.0);
  hit.v = std::clamp(w2 / sum, 0.0, 1.0 - hit.u);
}

// The t at which p + t (q - p), taken as lying in the triangle's plane (n its area
// normal), enters the triangle: the segment clipped by the three edges' inward normals
// within the plane. Where rounding leaves the clipped interval empty, its middle.
double EntryWithinPlane(const Vector3& p, const Vector3& q, const Triangle& tri, const Vector3& n) {
  const Vector3 d = q - p;
  double lo = 0;
  double hi = 1;
  const Vector3* corners[3] = {&tri.v0, &tri.v1, &tri.v2};
  for (int i = 0; i < 3; ++i) {
    const Vector3& a = *corners[i];
    const Vector3 inward = n.cross(*corners[(i + 1) % 3] - a);
    // inside this edge where inward . (p - a) + t inward . d >= 0
    const double start = inward.dot(p - a);
    const double rate = inward.dot(d);
    if (rate > 0) lo = std::max(lo, -start / rate);
    if (rate < 0) hi = std::min(hi, -start / rate);
  }
  return lo <= hi ? lo : std::clamp(0.5 * (lo + hi), 0.0, 1.0);
}

// True when the three exact edge signs agree (zeros agree with everything).
bool SignsAgree(int a, int b, int c) {
  const bool any_negative = a < 0 || b < 0 || c < 0;
  const bool any_positive = a > 0 || b > 0 || c > 0;
  return !(any_negative && any_positive);
}

bool AllFinite(const Vector3& a, const Vector3& b, const Triangle& tri) {
  return a.allFinite() && b.allFinite() && tri.v0.allFinite() && tri.v1.allFinite() &&
         tri.v2.allFinite();
}

}  // namespace

TriangleHit IntersectSegmentTriangle(const Vector3& p, const Vector3& q, const Triangle& tri) {
  return MollerTrumbore(p, q - p, tri, 1.0);
}

TriangleHit IntersectRayTriangle(const Vector3& origin, const Vector3& dir, const Triangle& tri) {
  return MollerTrumbore(origin, dir, tri, std::numeric_limits<double>::infinity());
}

TriangleHit IntersectSegmentTriangleWatertight(const Vector3& p, const Vector3& q,
                                               const Triangle& tri) {
  // Non-finite input would make every sign unreliable: a miss, never a NaN hit.
  if (!AllFinite(p, q, tri)) return {};
  // p and q on the same side of the plane, or both in it: a miss.
  const int side_p = Orient3d(tri.v0, tri.v1, tri.v2, p);
  const int side_q = Orient3d(tri.v0, tri.v1, tri.v2, q);
  if (side_p == side_q) return {};
  // The line pq passes all three directed edges the same way iff it meets the triangle.
  // Orient3d(p, q, a, b) = -Orient3d(p, q, b, a) exactly: a shared edge cannot let the
  // line slip between its two triangles.
  const int sign_01 = Orient3d(p, q, tri.v0, tri.v1);
  const int sign_12 = Orient3d(p, q, tri.v1, tri.v2);
  const int sign_20 = Orient3d(p, q, tri.v2, tri.v0);
  if (!SignsAgree(sign_01, sign_12, sign_20)) return {};

  TriangleHit hit{.hit = true};
  // t from the signed distances to the plane; an endpoint on the plane is exact.
  const Vector3 n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
  const double dist_p = n.dot(p - tri.v0);
  const double dist_q = n.dot(q - tri.v0);
  if (side_p == 0) {
    hit.t = 0;
  } else if (side_q == 0) {
    hit.t = 1;
  } else {
    // the rounded distances place the crossing only when they differ by more than their
    // rounding; a segment within rounding of the plane (the exact signs still say it
    // crosses) is on the plane all along, and it meets the triangle where it enters it
    const double rounding = 8 * std::numeric_limits<double>::epsilon() * n.norm() *
                            ((p - tri.v0).norm() + (q - tri.v0).norm());
    hit.t = std::abs(dist_p - dist_q) > rounding ? std::clamp(dist_p / (dist_p - dist_q), 0.0, 1.0)
                                                 : EntryWithinPlane(p, q, tri, n);
  }
  SetBarycentrics(p, q - p, tri, sign_01, sign_12, sign_20, hit);
  return hit;
}

TriangleHit IntersectRayTriangleWatertight(const Vector3& origin, const Vector3& dir,
                                           const Triangle& tri) {
  if (!AllFinite(origin, dir, tri)) return {};
  // Parallel to the plane (in it or not): a miss by convention.
  const int approach = OrientLineEdge(tri.v0, dir, tri.v1, tri.v2);  // sign of n . dir
  if (approach == 0) return {};
  // The origin must be on the plane or on the side the ray leaves from.
  const int side = Orient3d(tri.v0, tri.v1, tri.v2, origin);
  if (side == approach) return {};
  const int sign_01 = OrientLineEdge(origin, dir, tri.v0, tri.v1);
  const int sign_12 = OrientLineEdge(origin, dir, tri.v1, tri.v2);
  const int sign_20 = OrientLineEdge(origin, dir, tri.v2, tri.v0);
  if (!SignsAgree(sign_01, sign_12, sign_20)) return {};

  TriangleHit hit{.hit = true};
  if (side != 0) {
    const Vector3 n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
    // a ray parallel to the plane to rounding (n . dir rounds to 0 though its exact
    // sign does not) has no finite crossing to report: a miss, like an exactly parallel one
    const double t = -n.dot(origin - tri.v0) / n.dot(dir);
    if (!std::isfinite(t)) return {};
    hit.t = std::max(0.0, t);
  }
  SetBarycentrics(origin, dir, tri, sign_01, sign_12, sign_20, hit);
  return hit;
}

}  // namespace hapticd::geometry
