#include "server/geometry/capsule_triangle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/sphere_triangle.h"

namespace hapticd::geometry {
namespace {

const Triangle kTri{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};

// Independent oracles. The distance from the axis point p0 + s d to the triangle is
// convex in s, so a golden-section search over s finds the segment-triangle distance.
double OracleDistance(const Vector3& p0, const Vector3& p1, const Triangle& t) {
  const auto f = [&](double s) {
    return std::sqrt(FindClosestPointOnTriangle(p0 + s * (p1 - p0), t).distance_squared);
  };
  const double r = (std::sqrt(5.0) - 1) / 2;
  double lo = 0, hi = 1, m1 = hi - r * (hi - lo), m2 = lo + r * (hi - lo);
  double f1 = f(m1), f2 = f(m2);
  for (int i = 0; i < 100; ++i) {
    if (f1 <= f2) {
      hi = m2, m2 = m1, f2 = f1, m1 = hi - r * (hi - lo), f1 = f(m1);
    } else {
      lo = m1, m1 = m2, f1 = f2, m2 = lo + r * (hi - lo), f2 = f(m2);
    }
  }
  return std::min({f(0), f(1), f(0.5 * (lo + hi))});
}

// How far the axis must move along unit direction w before it no longer crosses the
// triangle: the set of crossing offsets is convex, so bisect on "still crossing".
double OracleEscapeAlong(const Capsule& c, const Triangle& t, const Vector3& w) {
  const auto crosses = [&](double lambda) {
    return CalcCapsuleTriangleContact({c.p0 + lambda * w, c.p1 + lambda * w, 0}, t).axis_crosses;
  };
  double lo = 0, hi = 1;
  while (crosses(hi) && hi < 1e3) hi *= 2;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (crosses(mid) ? lo : hi) = mid;
  }
  return hi;
}

TEST(CapsuleTriangle, LyingAboveTheFace) {
  const CapsuleTriangleContact c = CalcCapsuleTriangleContact({{1, 1, 1}, {2, 1, 1}, 1}, kTri);
  EXPECT_TRUE(c.touching);
  EXPECT_FALSE(c.axis_crosses);
  EXPECT_EQ(c.distance, 1);
  EXPECT_EQ(c.depth, 0);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  EXPECT_EQ(c.point_on_triangle.z(), 0);
  EXPECT_EQ(c.point_on_axis.z(), 1);
}

TEST(CapsuleTriangle, AxisPassingBesideAnEdge) {
  // axis parallel to z at x = -1: closest to edge v2-v0 (x = 0)
  const CapsuleTriangleContact c = CalcCapsuleTriangleContact({{-1, 1, -2}, {-1, 1, 2}, 1.5}, kTri);
  EXPECT_FALSE(c.axis_crosses);
  EXPECT_DOUBLE_EQ(c.distance, 1);
  EXPECT_DOUBLE_EQ(c.depth, 0.5);
  EXPECT_NEAR((c.normal - Vector3(-1, 0, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((c.point_on_triangle - Vector3(0, 1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR(c.s, 0.5, 1e-15);
}

TEST(CapsuleTriangle, CrossingPushesOutByTheShortestWay) {
  // shallow below: lifting the lower end (0.25) beats sliding out over an edge (1)
  CapsuleTriangleContact c = CalcCapsuleTriangleContact({{1, 1, -0.25}, {1, 1, 3}, 0.5}, kTri);
  EXPECT_TRUE(c.axis_crosses);
  EXPECT_EQ(c.distance, 0);
  EXPECT_EQ(c.depth, 0.75);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  EXPECT_EQ(c.point_on_axis, Vector3(1, 1, -0.25));
  EXPECT_EQ(c.point_on_triangle, Vector3(1, 1, 0));
  EXPECT_EQ(c.s, 0);
  // deep both ways, near the edge x = 0: slide out over it
  c = CalcCapsuleTriangleContact({{0.125, 1, -2}, {0.125, 1, 2}, 0.5}, kTri);
  EXPECT_TRUE(c.axis_crosses);
  EXPECT_DOUBLE_EQ(c.depth, 0.625);
  EXPECT_NEAR((c.normal - Vector3(-1, 0, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((c.point_on_axis - Vector3(0.125, 1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((c.point_on_triangle - Vector3(0, 1, 0)).norm(), 0, 1e-15);
  // deep below, shallow above: push down
  c = CalcCapsuleTriangleContact({{1, 1, -3}, {1, 1, 0.5}, 0.25}, kTri);
  EXPECT_EQ(c.normal, Vector3(0, 0, -1));
  EXPECT_EQ(c.depth, 0.75);
  EXPECT_EQ(c.s, 1);
}

TEST(CapsuleTriangle, TouchingExactly) {
  // an endpoint on the face, the axis above it: zero axis depth, pushed up
  CapsuleTriangleContact c = CalcCapsuleTriangleContact({{1, 1, 0}, {1, 2, 3}, 0.5}, kTri);
  EXPECT_TRUE(c.axis_crosses);
  EXPECT_EQ(c.depth, 0.5);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  // the axis through a point of an edge, across it: touching, zero axis depth
  c = CalcCapsuleTriangleContact({{2, -1, -1}, {2, 1, 1}, 0.5}, kTri);
  EXPECT_TRUE(c.axis_crosses);
  EXPECT_DOUBLE_EQ(c.depth, 0.5);
  // radius zero: the bare segment touching counts
  c = CalcCapsuleTriangleContact({{2, -1, -1}, {2, 1, 1}, 0}, kTri);
  EXPECT_TRUE(c.touching);
  // moved off the edge by a tiny exact step: a gap of that size
  const double tiny = std::ldexp(1.0, -40);
  c = CalcCapsuleTriangleContact({{2, -1 - tiny, -1}, {2, 1 - tiny, 1}, 0}, kTri);
  EXPECT_FALSE(c.axis_crosses);
  EXPECT_FALSE(c.touching);
  EXPECT_NEAR(c.distance, tiny / std::sqrt(2.0), 1e-25);
}

TEST(CapsuleTriangle, AxisInThePlane) {
  // crossing the triangle in its plane: no push direction, the face normal
  CapsuleTriangleContact c = CalcCapsuleTriangleContact({{-1, 1, 0}, {5, 1, 0}, 0.25}, kTri);
  EXPECT_TRUE(c.axis_in_plane);
  EXPECT_FALSE(c.axis_crosses);
  EXPECT_EQ(c.distance, 0);
  EXPECT_EQ(c.depth, 0.25);
  EXPECT_EQ(c.normal, Vector3(0, 0, 1));
  // inside it, and touching only a vertex
  EXPECT_TRUE(CalcCapsuleTriangleContact({{1, 1, 0}, {1.5, 1, 0}, 0}, kTri).axis_in_plane);
  EXPECT_TRUE(CalcCapsuleTriangleContact({{4, 0, 0}, {5, -1, 0}, 0}, kTri).axis_in_plane);
  // along an edge's line, overlapping it and past its end
  EXPECT_TRUE(CalcCapsuleTriangleContact({{-1, 0, 0}, {5, 0, 0}, 0}, kTri).axis_in_plane);
  EXPECT_TRUE(CalcCapsuleTriangleContact({{3, 0, 0}, {5, 0, 0}, 0}, kTri).axis_in_plane);
  // in the plane but apart: an in-plane push
  c = CalcCapsuleTriangleContact({{5, 0, 0}, {6, 1, 0}, 2}, kTri);
  EXPECT_FALSE(c.axis_in_plane);
  EXPECT_DOUBLE_EQ(c.distance, 1);
  EXPECT_NEAR((c.normal - Vector3(1, 0, 0)).norm(), 0, 1e-15);
  // and a point axis on the face
  c = CalcCapsuleTriangleContact({{1, 1, 0}, {1, 1, 0}, 0.5}, kTri);
  EXPECT_TRUE(c.axis_in_plane);
  EXPECT_EQ(c.depth, 0.5);
}

TEST(CapsuleTriangle, PointAxisMatchesTheSphere) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 1000; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Vector3 p(u(rng), u(rng), u(rng));
    const CapsuleTriangleContact c = CalcCapsuleTriangleContact({p, p, 0.3}, t);
    const SphereTriangleContact s = CalcSphereTriangleContact({p, 0.3}, t);
    EXPECT_NEAR(c.depth, s.depth, 1e-15);
    EXPECT_LE((c.normal - s.normal).norm(), 1e-12);
    EXPECT_LE((c.point_on_triangle - s.point).norm(), 1e-15);
  }
}

// Random capsules, against the oracles: distance (no crossing) by golden section;
// when crossing, moving along the normal by the axis depth frees the axis and no
// sampled direction frees it sooner.
TEST(CapsuleTriangle, RandomContactsMatchOracles) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(-1, 1);
  int crossing = 0;
  for (int n = 0; n < 3000; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Capsule cap{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, 0.2 * (1 + u(rng))};
    const CapsuleTriangleContact c = CalcCapsuleTriangleContact(cap, t);
    EXPECT_EQ(c.touching, c.depth >= 0);
    EXPECT_NEAR(c.normal.norm(), 1, 1e-14);
    EXPECT_LE((c.point_on_axis - (cap.p0 + c.s * (cap.p1 - cap.p0))).norm(), 1e-14);
    EXPECT_LE(FindClosestPointOnTriangle(c.point_on_triangle, t).distance_squared, 1e-24);
    // reversing the axis changes nothing but s
    const CapsuleTriangleContact r = CalcCapsuleTriangleContact({cap.p1, cap.p0, cap.radius}, t);
    EXPECT_NEAR(r.depth, c.depth, 1e-12);
    EXPECT_EQ(r.axis_crosses, c.axis_crosses);
    if (!c.axis_crosses) {
      EXPECT_NEAR(c.distance, OracleDistance(cap.p0, cap.p1, t), 1e-9) << "case " << n;
      EXPECT_DOUBLE_EQ(c.depth, cap.radius - c.distance);
      EXPECT_LE((c.point_on_axis - c.point_on_triangle - c.distance * c.normal).norm(), 1e-12);
      continue;
    }
    ++crossing;
    const double axis_depth = c.depth - cap.radius;
    EXPECT_GE(axis_depth, 0);
    EXPECT_LE((c.point_on_axis + axis_depth * c.normal - c.point_on_triangle).norm(), 1e-12)
        << "case " << n;
    // along the normal, the axis is freed just after axis_depth
    EXPECT_NEAR(OracleEscapeAlong(cap, t, c.normal), axis_depth, 1e-9) << "case " << n;
    // no other direction is shorter
    for (int k = 0; k < 20; ++k) {
      const Vector3 w = Vector3(u(rng), u(rng), u(rng)).normalized();
      EXPECT_GE(OracleEscapeAlong(cap, t, w), axis_depth - 1e-9) << "case " << n;
    }
  }
  EXPECT_GT(crossing, 100);
}

TEST(CapsuleTriangle, RigidMotionChangesNothing) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 2000; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Capsule cap{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, 0.3};
    const Matrix3 rot = Eigen::AngleAxisd(u(rng) * 3, Vector3(u(rng), u(rng), u(rng)).normalized())
                            .toRotationMatrix();
    const Vector3 shift(u(rng) * 10, u(rng) * 10, u(rng) * 10);
    const auto move = [&](const Vector3& p) { return Vector3(rot * p + shift); };
    const CapsuleTriangleContact c = CalcCapsuleTriangleContact(cap, t);
    const CapsuleTriangleContact m = CalcCapsuleTriangleContact(
        {move(cap.p0), move(cap.p1), cap.radius}, {move(t.v0), move(t.v1), move(t.v2)});
    EXPECT_NEAR(m.depth, c.depth, 1e-12);
    EXPECT_EQ(m.axis_crosses, c.axis_crosses);
    EXPECT_LE((m.normal - rot * c.normal).norm(), 1e-9) << "case " << n;
    EXPECT_LE((m.point_on_triangle - move(c.point_on_triangle)).norm(), 1e-9);
  }
}

TEST(CapsuleTriangle, NonFiniteInputReportsNoContact) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {nan, inf, -inf}) {
    EXPECT_FALSE(CalcCapsuleTriangleContact({{bad, 0, 0}, {1, 1, 1}, 1}, kTri).touching);
    EXPECT_FALSE(CalcCapsuleTriangleContact({{1, 1, -1}, {1, 1, 1}, bad}, kTri).touching);
    const Triangle t{{0, 0, 0}, {4, bad, 0}, {0, 4, 0}};
    EXPECT_FALSE(CalcCapsuleTriangleContact({{1, 1, -1}, {1, 1, 1}, 1}, t).touching);
  }
}

}  // namespace
}  // namespace hapticd::geometry
