#pragma once

// First contact of a moving sphere with a convex solid: the sweep a proxy makes against
// a primitive or a hull. Its centre moves c(t) = a + t (b - a), t in [0, 1]; the gap is
// g(t) = D(c(t)) - r, D the solid's signed distance (< 0 inside).
//
// Theory of operation. A proxy rests ON surfaces and slides along them, so touching is
// "g <= kConvexSweepTolerance", and a contact counts only when the motion goes into the
// surface: -(b - a) . n > 0, n the outward normal at the nearest surface point. Both
// kernels follow these rules; where the gap closes, the closed form stops where it is
// the tolerance and the advancement between there and the exact contact:
//  - SweepSphereConvex: any convex solid, asked through a distance oracle, by
//    conservative advancement over separating planes (the idea of van den Bergen's GJK
//    ray cast). At c(t) the nearest surface point and its normal n bound the solid by
//    the plane through that point; the sphere cannot touch the solid before its surface
//    reaches that plane, at t + g / (-(b - a) . n). Flat faces converge in one step,
//    curved surfaces in a few, from below: the iterates never pass the first contact.
//  - SweepSphereSphere: a ball, in closed form.
//
// Degenerate input, the same answer from both (ConvexSweepHit{}: a miss):
//  - any NaN or infinite a, b or r (or ball centre or radius), r < 0 (a ball's radius
//    < 0), or a == b (no motion): a miss, at once, the solid never asked.
//  - starting touching or inside (g(0) <= tolerance, however deep): a hit at t = 0,
//    with the nearest point and normal at a, when the motion goes in; a miss when it
//    is parallel to the surface or leaves it. So a resting sphere slides freely, and a
//    sphere inside is only held where it would go deeper. (A point leaving a solid from
//    inside is a ray-cast rule, the caller's: reverse the segment.)
//  - moving parallel to or away from the nearest surface while apart: a miss.
//  - first contact beyond t = 1: a miss; contact exactly at b (within the tolerance):
//    a hit at t <= 1.
//  - r = 0 is a point, swept by the same rules; a ball of radius 0 is its centre. A
//    point against a ball of radius 0 (a target 1e-10 wide) is below both kernels'
//    precision: a hit or a miss, unspecified, but never a NaN.
//  - a centre starting at the ball's centre: the normal is +x (CollideSpheres's
//    convention), so it is a hit at t = 0 exactly when the motion has x < 0.
//  - finite input whose squares overflow (magnitudes beyond about 1e150): unspecified,
//    but a hit's t is still in [0, 1].
//  - SweepSphereConvex only: the oracle finding nothing (found false) at any step, or
//    no contact within kMaxConvexSweepSteps steps (a non-converging oracle): a miss. A
//    NaN the oracle returns in its distance or normal ends the sweep in a miss. A hit's
//    point and normal are the oracle's, as it gave them.
// The closed form's discriminant B^2 - AC cancels where the path grazes the ball: it
// resolves a pass only to about 1e-8 of |a - centre| (the square root of the rounding),
// so a pass nearer touching than that may hit there where the advancement misses.
// A hit always has t in [0, 1]; nothing NaN comes out of finite oracle answers. Units
// are the caller's (m); all points in one frame. Pure, allocation-free, never throws.

#include <cmath>
#include <concepts>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// A sweep whose gap closes to this (m) has touched: far below what a hand can feel and
// far above the rounding of coordinates of a metre-sized scene.
constexpr double kConvexSweepTolerance = 1e-10;
// Advancement converges in a few steps on curved surfaces and in one on flat ones; this
// bound only guards against an oracle that does not converge.
constexpr int kMaxConvexSweepSteps = 64;

struct ConvexSweepHit {
  bool hit = false;
  double t = 0;  // first contact: centre = a + t (b - a), t in [0, 1]
  Vector3 point = Vector3::Zero();    // the solid's surface point nearest the centre then
  Vector3 normal = Vector3::UnitZ();  // unit, outward there (towards the centre)
};

// What a distance oracle answers for a point p.
struct ConvexProbe {
  bool found = false;          // false: the solid has no answer for p (the sweep misses)
  double signed_distance = 0;  // of p from the surface: < 0 inside
  Vector3 point = Vector3::Zero();    // the nearest surface point
  Vector3 normal = Vector3::UnitZ();  // unit, outward there (from the solid towards p)
};

// A convex solid's signed distance: ConvexProbe oracle(const Vector3& p).
template <typename F>
concept ConvexDistanceOracle = requires(const F& oracle, const Vector3& p) {
  { oracle(p) } -> std::convertible_to<ConvexProbe>;
};

// First contact of a sphere of radius r, its centre moving a -> b, with the convex
// solid whose distance oracle answers, under the rules above (at most
// kMaxConvexSweepSteps calls of oracle). For a non-convex solid the answer may come
// late (a plane of the nearest point does not bound it).
template <ConvexDistanceOracle Oracle>
ConvexSweepHit SweepSphereConvex(const Oracle& oracle, const Vector3& a, const Vector3& b, double r) {
  ConvexSweepHit sweep;
  if (!a.allFinite() || !b.allFinite() || !(r >= 0) || !std::isfinite(r) || a == b) return sweep;
  const Vector3 motion = b - a;
  double t = 0;
  for (int step = 0; step < kMaxConvexSweepSteps; ++step) {
    const ConvexProbe probe = oracle(Vector3(a + t * motion));
    if (!probe.found) return sweep;
    const double gap = probe.signed_distance - r;
    const double approach = -motion.dot(probe.normal);
    if (gap <= kConvexSweepTolerance) {
      // touching (at the start, or arrived) counts only when the motion goes in
      if (!(approach > 0)) return sweep;
      sweep.hit = true;
      sweep.t = t;
      sweep.point = probe.point;
      sweep.normal = probe.normal;
      return sweep;
    }
    // parallel to or away from the separating plane (or a NaN): never touches
    if (!(approach > 0)) return sweep;
    t += gap / approach;
    if (!(t <= 1)) return sweep;
  }
  return sweep;
}

// First contact of a sphere of radius r, its centre moving a -> b, with the closed ball
// `ball`, under the rules above: the t at which the gap first falls to the tolerance,
// where SweepSphereConvex's advancement would stop.
ConvexSweepHit SweepSphereSphere(const Sphere& ball, const Vector3& a, const Vector3& b, double r);

}  // namespace hapticd::geometry
