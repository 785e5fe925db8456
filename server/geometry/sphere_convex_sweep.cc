#include "server/geometry/sphere_convex_sweep.h"

#include "server/geometry/sphere_sphere.h"

namespace hapticd::geometry {

// With m = a - centre, d = b - a and rho = R + r + tolerance, the gap reaches the
// tolerance where |m + t d|^2 = rho^2, i.e. A t^2 + 2 B t + C = 0 with A = |d|^2,
// B = m . d, C = |m|^2 - rho^2. From outside (C > 0) the centre approaches only when
// B < 0, and the first root is C / (-B + sqrt(B^2 - AC)), the form that loses nothing to
// cancellation. SweepSphereConvex's iterates approach that root from below.
ConvexSweepHit SweepSphereSphere(const Sphere& ball, const Vector3& a, const Vector3& b, double r) {
  ConvexSweepHit sweep;
  if (!a.allFinite() || !b.allFinite() || !(r >= 0) || !std::isfinite(r) || a == b ||
      !ball.center.allFinite() || !(ball.radius >= 0) || !std::isfinite(ball.radius)) {
    return sweep;
  }
  const Vector3 motion = b - a;
  const Vector3 m = a - ball.center;
  const double rho = ball.radius + r + kConvexSweepTolerance;
  const double B = m.dot(motion);
  const double C = m.squaredNorm() - rho * rho;
  double t = 0;
  // outside (or a NaN from overflow, which then misses)
  if (!(C <= 0)) {
    // moving away, or passing by
    const double discriminant = B * B - motion.squaredNorm() * C;
    if (!(B < 0) || !(discriminant >= 0)) return sweep;
    t = C / (-B + std::sqrt(discriminant));
    if (!(t <= 1)) return sweep;
  }
  // the nearest point of the ball and its normal there, as CollideSpheres(ball, {x, 0})
  // gives them (+x where x is the centre), without its exact sign of the gap, which the
  // sweep does not use; an x that overflowed goes to CollideSpheres itself
  const Vector3 x = a + t * motion;
  Vector3 normal;
  Vector3 point;
  if (x.allFinite()) {
    normal = CalcCenterLine(ball.center, x).direction;
    point = ball.center + ball.radius * normal;
  } else {
    const SphereSphereResult contact = CollideSpheres(ball, {x, 0});
    normal = contact.normal;
    point = contact.point_a;
  }
  // touching or inside at the start: only motion into the ball hits
  if (C <= 0 && !(-motion.dot(normal) > 0)) return sweep;
  sweep.hit = true;
  sweep.t = t;
  sweep.point = point;
  sweep.normal = normal;
  return sweep;
}

}  // namespace hapticd::geometry
