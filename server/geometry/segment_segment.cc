#include "server/geometry/segment_segment.h"

#include <limits>

namespace hapticd::geometry {
namespace {

// Below this sin² of the angle between the segments, the line-line solution is too
// ill-conditioned to trust alone, and the endpoint candidates are compared as well.
constexpr double kNearlyParallel = 1e-8;

// Clamps to [0, 1]; NaN passes through.
double Clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }

SegmentSegmentClosest MakeResult(const Vector3& p0, const Vector3& d1, const Vector3& q0,
                                 const Vector3& d2, double s, double t) {
  SegmentSegmentClosest r;
  r.s = s;
  r.t = t;
  r.point_a = p0 + s * d1;
  r.point_b = q0 + t * d2;
  r.distance_squared = (r.point_a - r.point_b).squaredNorm();
  return r;
}

}  // namespace

// Minimise |p0 + s d1 - (q0 + t d2)|² over the unit square, with r = p0 - q0,
// a = d1·d1, b = d1·d2, c = d1·r, e = d2·d2, f = d2·r. For fixed s the best t is
// (b s + f) / e, for fixed t the best s is (b t - c) / a. The lines' closest pair has
// s = (b f - c e) / (a e - b²); clamp it, take the best t for it, and if that t is
// clamped, the best s for the clamped t (Ericson 5.1.9). The quadratic is convex, so
// this finds the minimum when a e - b² > 0. When the segments are (nearly) parallel,
// that solution is unreliable, but the minimum is then (to within rounding) attained
// with one parameter at an end of its range: compare the four endpoint candidates.
SegmentSegmentClosest FindClosestPointsBetweenSegments(const Vector3& p0, const Vector3& p1,
                                                       const Vector3& q0, const Vector3& q1) {
  if (!(p0.allFinite() && p1.allFinite() && q0.allFinite() && q1.allFinite())) {
    constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
    return {kNan, kNan, Vector3::Constant(kNan), Vector3::Constant(kNan), kNan};
  }
  const Vector3 d1 = p1 - p0;
  const Vector3 d2 = q1 - q0;
  const Vector3 r = p0 - q0;
  const double a = d1.squaredNorm();
  const double e = d2.squaredNorm();
  const double f = d2.dot(r);

  // both segments are points
  if (a == 0 && e == 0) return MakeResult(p0, d1, q0, d2, 0, 0);
  // segment a is a point: closest point of b to it
  if (a == 0) return MakeResult(p0, d1, q0, d2, 0, Clamp01(f / e));
  const double c = d1.dot(r);
  // segment b is a point: closest point of a to it
  if (e == 0) return MakeResult(p0, d1, q0, d2, Clamp01(-c / a), 0);

  // the general case
  const double b = d1.dot(d2);
  const double denom = a * e - b * b;
  double s = denom > 0 ? Clamp01((b * f - c * e) / denom) : 0;
  double t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = Clamp01(-c / a);
  } else if (t > 1) {
    t = 1;
    s = Clamp01((b - c) / a);
  }
  SegmentSegmentClosest best = MakeResult(p0, d1, q0, d2, s, t);
  if (denom > kNearlyParallel * a * e) return best;

  // (nearly) parallel: also try each endpoint against the other segment
  const SegmentSegmentClosest candidates[] = {
      MakeResult(p0, d1, q0, d2, 0, Clamp01(f / e)),
      MakeResult(p0, d1, q0, d2, 1, Clamp01((b + f) / e)),
      MakeResult(p0, d1, q0, d2, Clamp01(-c / a), 0),
      MakeResult(p0, d1, q0, d2, Clamp01((b - c) / a), 1),
  };
  for (const SegmentSegmentClosest& candidate : candidates) {
    if (candidate.distance_squared < best.distance_squared) best = candidate;
  }
  return best;
}

}  // namespace hapticd::geometry
