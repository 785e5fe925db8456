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
// signed volumes against the three directed edges (w0 = dir . ((v1 - o) x (v2 - o)),
// the volume of the edge opposite v0, and so on). An exactly-zero sign pins that weight
// to zero, so a touching edge or vertex reports u, v exactly on the boundary.
void SetBarycentrics(double w0, double w1, double w2, int sign_01, int sign_12, int sign_20,
                     TriangleHit& hit) {
  if (sign_12 == 0) w0 = 0;
  if (sign_20 == 0) w1 = 0;
  if (sign_01 == 0) w2 = 0;
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

// dir . ((a - o) x (b - o)), evaluated as FilterSegmentTriangle evaluates it.
double LineEdgeVolume(const Vector3& o, const Vector3& dir, const Vector3& a, const Vector3& b) {
  return dir.dot((a - o).cross(b - o));
}

void SetBarycentrics(const Vector3& o, const Vector3& dir, const Triangle& tri, int sign_01,
                     int sign_12, int sign_20, TriangleHit& hit) {
  SetBarycentrics(LineEdgeVolume(o, dir, tri.v1, tri.v2), LineEdgeVolume(o, dir, tri.v2, tri.v0),
                  LineEdgeVolume(o, dir, tri.v0, tri.v1), sign_01, sign_12, sign_20, hit);
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

// Whether gap > 8 eps |n| (|a| + |b|), the rounding of two plane distances n . a and
// n . b, evaluated as written. Most crossings clear it by orders of magnitude, and
// (|a| + |b|)^2 <= 2 (|a|^2 + |b|^2) decides those without the three square roots: with
// every squared magnitude within [1e-100, 1e100] nothing over- or underflows, and the
// factor 2.01 covers the rounding of both sides (a few ulps each), so gap^2 above it
// means gap above the rounding as written. The rest compare as written.
bool ExceedsDistanceRounding(double gap, const Vector3& n, const Vector3& a, const Vector3& b) {
  constexpr double k = 8 * std::numeric_limits<double>::epsilon();
  const double gap2 = gap * gap;
  const double n2 = n.squaredNorm();
  const double s2 = a.squaredNorm() + b.squaredNorm();
  const auto in_range = [](double x) { return x >= 1e-100 && x <= 1e100; };
  if (in_range(gap2) && in_range(n2) && in_range(s2) && gap2 > 2.01 * k * k * n2 * s2) return true;
  return gap > k * n.norm() * (a.norm() + b.norm());
}

// t, u and v of a hit, once the exact signs (sides of p and q, line against the edges)
// say that p -> q meets the triangle. Shared by the filtered and the exact decisions,
// so that both report the same numbers.
// volumes: w0, w1, w2 as SetBarycentrics takes them.
TriangleHit CompleteSegmentHit(const Vector3& p, const Vector3& q, const Triangle& tri,
                               int side_p, int side_q, int sign_01, int sign_12, int sign_20,
                               const double volumes[3]) {
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
    hit.t = ExceedsDistanceRounding(std::abs(dist_p - dist_q), n, p - tri.v0, q - tri.v0)
                ? std::clamp(dist_p / (dist_p - dist_q), 0.0, 1.0)
                : EntryWithinPlane(p, q, tri, n);
  }
  SetBarycentrics(volumes[0], volumes[1], volumes[2], sign_01, sign_12, sign_20, hit);
  return hit;
}

// Shewchuk's first-stage bound for a 3x3 determinant of differences of the inputs is
// (7 + 56 eps) eps times its permanent; the filter below bounds the permanents by the
// coordinates' largest magnitude and rounds that bound up generously with 8 eps.
constexpr double kHalfUlp = std::numeric_limits<double>::epsilon() / 2;
constexpr double kDeterminantErrorBound = 8 * kHalfUlp;
// Added to every bound: products that underflow lose their relative accuracy, and their
// absolute error, scaled by coordinates up to 1e100, stays below this.
constexpr double kUnderflowGuard = 1e-200;

// The five signs the watertight segment test decides on, when floating point proves
// them all (answer kHit, signs as Orient3d gives them) or proves a miss whatever the
// undecided ones are (kMiss); kUndecided otherwise, and on non-finite input that does
// not already prove a miss (the exact test then answers). volumes: the line's rounded
// volumes against the edges, for SetBarycentrics.
struct FilteredSigns {
  enum Answer { kMiss, kHit, kUndecided } answer = kUndecided;
  int side_p = 0, side_q = 0, sign_01 = 0, sign_12 = 0, sign_20 = 0;
  double volumes[3] = {};
};

// With a = v0 - p, b = v1 - p, c = v2 - p and d = q - p (rounded):
//   Orient3d(p, q, v0, v1) = sign d . (a x b), and so on around the edges;
//   Orient3d(v0, v1, v2, p) = -sign a . (b x c)  (the volume det[a, b, c]);
//   Orient3d(v0, v1, v2, q) = -sign det[a - d, b - d, c - d]
//                           = -sign (det[a, b, c] - d.(a x b) - d.(b x c) - d.(c x a)),
// the last exactly by multilinearity, so q's side costs three subtractions, and its
// bound the sum of the four bounds plus the rounding of those subtractions. Each of the
// first four is a determinant of rounded differences of the inputs, evaluated as
// Orient3d's filter evaluates one; with m the largest |coordinate| of a, b, c, the
// permanent of d . (a x b) is at most 2 |d|_1 m^2 and that of det[a, b, c] 6 m^3.
FilteredSigns FilterSegmentTriangle(const Vector3& p, const Vector3& q, const Triangle& tri) {
  const double dx = q.x() - p.x(), dy = q.y() - p.y(), dz = q.z() - p.z();
  const double ax = tri.v0.x() - p.x(), ay = tri.v0.y() - p.y(), az = tri.v0.z() - p.z();
  const double bx = tri.v1.x() - p.x(), by = tri.v1.y() - p.y(), bz = tri.v1.z() - p.z();
  const double cx = tri.v2.x() - p.x(), cy = tri.v2.y() - p.y(), cz = tri.v2.z() - p.z();
  const auto cross = [](double ux, double uy, double uz, double vx, double vy, double vz,
                        double out[3]) {
    out[0] = uy * vz - uz * vy;
    out[1] = uz * vx - ux * vz;
    out[2] = ux * vy - uy * vx;
  };
  double ab[3], bc[3], ca[3];
  cross(ax, ay, az, bx, by, bz, ab);
  cross(bx, by, bz, cx, cy, cz, bc);
  cross(cx, cy, cz, ax, ay, az, ca);
  const auto dot = [](double wx, double wy, double wz, const double v[3]) {
    return wx * v[0] + wy * v[1] + wz * v[2];
  };
  const double s01 = dot(dx, dy, dz, ab);
  const double s12 = dot(dx, dy, dz, bc);
  const double s20 = dot(dx, dy, dz, ca);
  const double vp = dot(ax, ay, az, bc);
  const double m = std::max({std::abs(ax), std::abs(ay), std::abs(az), std::abs(bx), std::abs(by),
                             std::abs(bz), std::abs(cx), std::abs(cy), std::abs(cz)});
  const double m2 = m * m;
  const double d1 = std::abs(dx) + std::abs(dy) + std::abs(dz);
  const double e_edge = kDeterminantErrorBound * (2 * d1 * m2) + kUnderflowGuard;
  const double e_p = kDeterminantErrorBound * (6 * m * m2) + kUnderflowGuard;
  // the four errors, summed with room for that sum's rounding, and the three subtractions'
  const double vq = ((vp - s01) - s12) - s20;
  const double e_q = (e_p + 3 * e_edge) * (1 + 8 * kHalfUlp) +
                     4 * kHalfUlp * (std::abs(vp) + std::abs(s01) + std::abs(s12) + std::abs(s20));

  FilteredSigns f;
  // a miss whatever the rest: the line passes two edges opposite ways, or p and q lie
  // strictly on one side (NaN compares false and proves nothing)
  const bool any_positive = s01 > e_edge || s12 > e_edge || s20 > e_edge;
  const bool any_negative = s01 < -e_edge || s12 < -e_edge || s20 < -e_edge;
  const bool one_side = (vp > e_p && vq > e_q) || (vp < -e_p && vq < -e_q);
  if ((any_positive && any_negative) || one_side) {
    f.answer = FilteredSigns::kMiss;
    return f;
  }
  const bool all_known = std::abs(s01) > e_edge && std::abs(s12) > e_edge &&
                         std::abs(s20) > e_edge && std::abs(vp) > e_p && std::abs(vq) > e_q;
  if (!all_known) return f;
  // every sign proven, the edges agree and p, q lie strictly on opposite sides: a hit
  f.answer = FilteredSigns::kHit;
  f.side_p = vp > 0 ? -1 : 1;
  f.side_q = -f.side_p;
  f.sign_01 = f.sign_12 = f.sign_20 = any_positive ? 1 : -1;
  f.volumes[0] = s12;
  f.volumes[1] = s20;
  f.volumes[2] = s01;
  return f;
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
  const FilteredSigns f = FilterSegmentTriangle(p, q, tri);
  if (f.answer == FilteredSigns::kMiss) return {};
  if (f.answer == FilteredSigns::kUndecided) return IntersectSegmentTriangleWatertightUnfiltered(p, q, tri);
  return CompleteSegmentHit(p, q, tri, f.side_p, f.side_q, f.sign_01, f.sign_12, f.sign_20,
                            f.volumes);
}

TriangleHit IntersectSegmentTriangleWatertightUnfiltered(const Vector3& p, const Vector3& q,
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
  const Vector3 d = q - p;
  const double volumes[3] = {LineEdgeVolume(p, d, tri.v1, tri.v2), LineEdgeVolume(p, d, tri.v2, tri.v0),
                             LineEdgeVolume(p, d, tri.v0, tri.v1)};
  return CompleteSegmentHit(p, q, tri, side_p, side_q, sign_01, sign_12, sign_20, volumes);
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
