#include "server/geometry/capsule_box.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace hapticd::geometry {
namespace {

// Gaps below this fraction of the scale of the input are rounding noise: the capsule's
// segment is then treated as touching the box, so the normal comes from the box's
// geometry rather than from the direction of that noise.
constexpr double kTouchTolerance = 1e-12;

bool IsFinite(const Box& box) {
  return box.center.allFinite() && box.rotation.allFinite() && box.half_extents.allFinite();
}

// Closest points in the box frame B, where the box is [-h, h].
struct LocalClosest {
  double t = 0;
  Vector3 s = Vector3::Zero();  // segment point
  Vector3 q = Vector3::Zero();  // box point
  double distance_squared = 0;
};

LocalClosest Evaluate(const Vector3& P, const Vector3& D, const Vector3& h, double t) {
  LocalClosest c;
  c.t = t;
  c.s = P + t * D;
  c.q = c.s.cwiseMax(-h).cwiseMin(h);
  c.distance_squared = (c.s - c.q).squaredNorm();
  return c;
}

// Derivation. In B the squared distance from x to the box is
// sum_i (x_i - clamp(x_i, -h_i, h_i))^2, and for x = s(t) = P + t D each term is 0
// while |s_i(t)| <= h_i and (P_i -+ h_i + t D_i)^2 beyond. So f(t) is convex (the
// distance to a convex set along a line), piecewise quadratic, with breakpoints where
// s_i(t) = +-h_i: t = (+-h_i - P_i) / D_i. Between two consecutive breakpoints each axis
// is in one state, read off at the midpoint, so the piece is
// f(t) = sum_{active i} (o_i + t D_i)^2 = A t^2 + B t + C with A = sum D_i^2 and
// B = 2 sum o_i D_i, o_i = P_i - h_i above the slab and P_i + h_i below it. Its
// minimiser on [t0, t1] is clamp(-B / 2A, t0, t1), or any point where A = 0 (then f
// is constant). Walking the pieces in order, the first whose minimiser lies before its
// end holds the global minimum (f is convex, so it only grows after that point). Each
// candidate is re-evaluated directly from s(t), not from the expanded quadratic, and
// the smallest is the answer.
LocalClosest FindClosestLocal(const Vector3& P, const Vector3& D, const Vector3& h) {
  // Breakpoints inside (0, 1), plus both ends; NaN never passes the range test.
  std::array<double, 8> ts;
  int count = 0;
  ts[count++] = 0;
  for (int i = 0; i < 3; ++i) {
    if (D[i] == 0) continue;
    for (const double bound : {-h[i], h[i]}) {
      const double t = (bound - P[i]) / D[i];
      if (t > 0 && t < 1) ts[count++] = t;
    }
  }
  ts[count++] = 1;
  // Insertion sort of the (finite) interior breakpoints.
  for (int i = 2; i < count - 1; ++i) {
    for (int k = i; k > 1 && ts[k] < ts[k - 1]; --k) std::swap(ts[k], ts[k - 1]);
  }

  // Minimise each piece in closed form; keep the best.
  LocalClosest best = Evaluate(P, D, h, 0);
  for (int k = 0; k + 1 < count; ++k) {
    const double t0 = ts[k];
    const double t1 = ts[k + 1];
    const Vector3 mid = P + (0.5 * (t0 + t1)) * D;
    double A = 0;
    double B = 0;
    for (int i = 0; i < 3; ++i) {
      double offset;
      if (mid[i] > h[i]) {
        offset = P[i] - h[i];
      } else if (mid[i] < -h[i]) {
        offset = P[i] + h[i];
      } else {
        continue;
      }
      A += D[i] * D[i];
      B += 2 * offset * D[i];
    }
    // Degenerate piece (A == 0): f is constant there; take its middle, which is
    // exactly inside the box when the piece is (a boundary point may round outside).
    double t = 0.5 * (t0 + t1);
    if (A > 0) t = std::clamp(-B / (2 * A), t0, t1);
    const LocalClosest c = Evaluate(P, D, h, t);
    if (c.distance_squared < best.distance_squared) best = c;
    // f is convex: once a piece's minimum lies before its end, f only grows after it.
    if (t < t1 || best.distance_squared == 0) break;
  }
  return best;
}

// Penetration depth of a segment P-Q that touches or enters the box [-h, h], in B.
// Derivation: the translations v for which P+v..Q+v meets the box form the convex
// polytope K = box (+) (-segment); the depth is the distance from the origin (inside
// K) to K's boundary, min over K's facet normals n of its support
// h_K(n) = sum_i h_i |n_i| + max(-n.P, -n.Q). K's facets have the normals +-e_i (box
// faces) and +-(e_k x D) / |e_k x D| (a box edge swept along the segment). Any other
// unit direction would only give a larger support, so the minimum over this set is
// exact. For n perpendicular to D, n.P == n.Q and the pair +-n costs
// sum h_i |n_i| - |n.P|.
struct LocalPenetration {
  double depth = 0;
  Vector3 normal = Vector3::UnitX();
};

LocalPenetration FindSegmentPenetration(const Vector3& P, const Vector3& Q,
                                        const Vector3& h) {
  LocalPenetration best;
  best.depth = std::numeric_limits<double>::infinity();
  // The six box faces, + before -.
  for (int i = 0; i < 3; ++i) {
    const double plus = h[i] - std::min(P[i], Q[i]);
    const double minus = h[i] + std::max(P[i], Q[i]);
    if (plus < best.depth) best = {plus, Vector3::Unit(i)};
    if (minus < best.depth) best = {minus, -Vector3::Unit(i)};
  }
  // Box edge k swept along the segment; skipped where parallel (zero cross product).
  const Vector3 D = Q - P;
  for (int k = 0; k < 3; ++k) {
    const Vector3 c = Vector3::Unit(k).cross(D);
    const double length = c.norm();
    if (!(length > 0)) continue;
    const Vector3 n = c / length;
    const double along = n.dot(P);
    const double depth = h.dot(n.cwiseAbs()) - std::abs(along);
    if (depth < best.depth) best = {depth, along < 0 ? Vector3(-n) : n};
  }
  // Non-finite input leaves no candidate: report zero depth along +x.
  if (!(best.depth < std::numeric_limits<double>::infinity())) best = {0, Vector3::UnitX()};
  return best;
}

}  // namespace

SegmentBoxClosestPoints FindClosestPointsSegmentBox(const Vector3& p0, const Vector3& p1,
                                                    const Box& box) {
  // Non-finite input: nothing found, as far away as a double can say.
  if (!p0.allFinite() || !p1.allFinite() || !IsFinite(box)) {
    SegmentBoxClosestPoints nothing;
    nothing.distance_squared = std::numeric_limits<double>::max();
    return nothing;
  }
  const Matrix3& R_WB = box.rotation;
  const Vector3 P = R_WB.transpose() * (p0 - box.center);
  const Vector3 D = R_WB.transpose() * (p1 - p0);
  const LocalClosest local = FindClosestLocal(P, D, box.half_extents);
  SegmentBoxClosestPoints result;
  result.t = local.t;
  result.point_segment = p0 + local.t * (p1 - p0);
  result.point_box = box.center + R_WB * local.q;
  result.distance_squared = local.distance_squared;
  return result;
}

CapsuleBoxResult CollideCapsuleBox(const Capsule& capsule, const Box& box) {
  CapsuleBoxResult result;
  // Non-finite input: no contact, every field zero (the normal included).
  if (!capsule.p0.allFinite() || !capsule.p1.allFinite() || !std::isfinite(capsule.radius) ||
      !IsFinite(box)) {
    result.normal = Vector3::Zero();
    return result;
  }
  const Matrix3& R_WB = box.rotation;
  const Vector3& h = box.half_extents;
  const double r = capsule.radius;
  // The segment in the box frame B.
  const Vector3 P = R_WB.transpose() * (capsule.p0 - box.center);
  const Vector3 Q = R_WB.transpose() * (capsule.p1 - box.center);
  const Vector3 D = Q - P;
  const LocalClosest closest = FindClosestLocal(P, D, h);

  Vector3 n_B;
  Vector3 q_B;  // box witness
  Vector3 s_B;  // segment point behind the capsule witness
  const double scale = P.cwiseAbs().maxCoeff() + Q.cwiseAbs().maxCoeff() + h.maxCoeff();
  const double touch_gap = kTouchTolerance * scale;
  if (closest.distance_squared > touch_gap * touch_gap) {
    // Segment outside the box: the capsule adds its radius to the gap.
    const double gap = std::sqrt(closest.distance_squared);
    n_B = (closest.s - closest.q) / gap;
    q_B = closest.q;
    s_B = closest.s;
    result.distance = gap - r;
    result.intersect = closest.distance_squared <= r * r;
  } else {
    // Segment touches or enters the box (or misses it by rounding noise): its
    // penetration depth (down to -touch_gap) plus the radius.
    const LocalPenetration pen = FindSegmentPenetration(P, Q, h);
    n_B = pen.normal;
    // Witnesses: translate the segment out by depth * n, find where it touches the
    // box, and map that segment point back.
    const Vector3 v = pen.depth * pen.normal;
    const LocalClosest contact = FindClosestLocal(P + v, D, h);
    q_B = contact.q;
    s_B = contact.s - v;
    result.distance = -(pen.depth + r);
    result.intersect = true;
  }
  // Back to the world frame.
  result.normal = R_WB * n_B;
  result.point_box = box.center + R_WB * q_B;
  result.point_capsule = box.center + R_WB * s_B - r * result.normal;
  return result;
}

}  // namespace hapticd::geometry
