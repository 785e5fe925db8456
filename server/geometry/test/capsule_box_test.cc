#include "server/geometry/capsule_box.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/sphere_box.h"
#include "server/geometry/test/box_surface.h"
#include "server/geometry/test/non_finite.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

// Oracle: the distance from a point to the solid box, through the triangles.
double OraclePointBoxDistance(const Vector3& p, const Box& box,
                              const std::array<Triangle, 12>& triangles) {
  const Vector3 local = box.rotation.transpose() * (p - box.center);
  if ((local.array().abs() <= box.half_extents.array()).all()) return 0;
  double d2 = std::numeric_limits<double>::infinity();
  for (const Triangle& t : triangles) {
    d2 = std::min(d2, FindClosestPointOnTriangle(p, t).distance_squared);
  }
  return std::sqrt(d2);
}

// Oracle: the segment-box distance by golden-section search on t (the distance from
// s(t) to a convex set is convex in t), independent of the piecewise solution.
double OracleSegmentBoxDistance(const Vector3& p0, const Vector3& p1, const Box& box) {
  const std::array<Triangle, 12> triangles = FaceTriangles(box);
  const auto f = [&](double t) {
    return OraclePointBoxDistance(p0 + t * (p1 - p0), box, triangles);
  };
  const double phi = (std::sqrt(5.0) - 1) / 2;
  double a = 0;
  double b = 1;
  double c = b - phi * (b - a);
  double d = a + phi * (b - a);
  double fc = f(c);
  double fd = f(d);
  for (int i = 0; i < 80; ++i) {
    if (fc < fd) {
      b = d, d = c, fd = fc;
      c = b - phi * (b - a);
      fc = f(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + phi * (b - a);
      fd = f(d);
    }
  }
  return std::min({f(0), f(1), fc, fd});
}

// Oracle: does the segment meet the closed box? Slab clipping (Liang-Barsky).
bool SegmentMeetsBox(const Vector3& p0, const Vector3& p1, const Box& box) {
  const Vector3 P = box.rotation.transpose() * (p0 - box.center);
  const Vector3 D = box.rotation.transpose() * (p1 - p0);
  double t_in = 0;
  double t_out = 1;
  for (int i = 0; i < 3; ++i) {
    const double h = box.half_extents[i];
    if (D[i] == 0) {
      if (std::abs(P[i]) > h) return false;
      continue;
    }
    double t0 = (-h - P[i]) / D[i];
    double t1 = (h - P[i]) / D[i];
    if (t0 > t1) std::swap(t0, t1);
    t_in = std::max(t_in, t0);
    t_out = std::min(t_out, t1);
  }
  return t_in <= t_out;
}

// Oracle: how far the segment must move along unit u to leave the box (bisection).
double ExitDistanceAlong(const Vector3& p0, const Vector3& p1, const Box& box, const Vector3& u) {
  double lo = 0;
  double hi = 2 * (p0.norm() + p1.norm() + box.center.norm() + box.half_extents.sum()) + 1;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (SegmentMeetsBox(p0 + mid * u, p1 + mid * u, box) ? lo : hi) = mid;
  }
  return hi;
}

// The witnesses: point_capsule - point_box = distance * normal; point_box in the box.
void ExpectConsistent(const Capsule& c, const Box& box, const CapsuleBoxResult& r, double tol) {
  EXPECT_NEAR(r.normal.norm(), 1.0, 1e-12);
  const Vector3 local = box.rotation.transpose() * (r.point_box - box.center);
  EXPECT_TRUE((local.array().abs() <= box.half_extents.array() + tol).all());
  EXPECT_LT((r.point_capsule - r.point_box - r.distance * r.normal).norm(), tol);
  // point_capsule is radius away from a point of the segment.
  const Vector3 axis_point = r.point_capsule + c.radius * r.normal;
  const Vector3 d = c.p1 - c.p0;
  const double t =
      d.squaredNorm() > 0 ? std::clamp((axis_point - c.p0).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0;
  EXPECT_LT((c.p0 + t * d - axis_point).norm(), tol);
}

Box RandomBox(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> coord(-1, 1);
  std::uniform_real_distribution<double> extent(0.05, 1);
  return {{coord(rng), coord(rng), coord(rng)}, RandomRotation(rng),
          {extent(rng), extent(rng), extent(rng)}};
}

const Box kCube{{0, 0, 0}, Matrix3::Identity(), {1, 1, 1}};

TEST(CapsuleBoxTest, ParallelToFace) {
  const CapsuleBoxResult r = CollideCapsuleBox({{2, -3, 0.5}, {2, 3, 0.5}, 0.5}, kCube);
  EXPECT_FALSE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, 0.5);
  EXPECT_EQ(r.normal, Vector3(1, 0, 0));
  EXPECT_NEAR(r.point_box.x(), 1, 1e-15);
  EXPECT_NEAR(r.point_capsule.x(), 1.5, 1e-15);
}

// Skew to the cube: the segment runs along x + y = 2 at height z = 2 and passes right
// above the corner (1, 1, 1), one unit away, at its midpoint.
TEST(CapsuleBoxTest, SkewOverCorner) {
  const CapsuleBoxResult r = CollideCapsuleBox({{3, -1, 2}, {-1, 3, 2}, 0.25}, kCube);
  EXPECT_DOUBLE_EQ(r.distance, 0.75);
  EXPECT_TRUE(r.normal.isApprox(Vector3(0, 0, 1), 1e-15));
  // Touching exactly with radius 1.
  const CapsuleBoxResult touch = CollideCapsuleBox({{3, -1, 2}, {-1, 3, 2}, 1}, kCube);
  EXPECT_TRUE(touch.intersect);
  EXPECT_EQ(touch.distance, 0);
}

// A segment touching a box edge exactly: distance 0, intersecting even at radius 0.
TEST(CapsuleBoxTest, SegmentTouchingEdge) {
  const SegmentBoxClosestPoints c = FindClosestPointsSegmentBox({2, 0, 0}, {0, 2, 0}, kCube);
  EXPECT_EQ(c.distance_squared, 0);
  EXPECT_EQ(c.point_segment, Vector3(1, 1, 0));
  const CapsuleBoxResult r = CollideCapsuleBox({{2, 0, 0}, {0, 2, 0}, 0}, kCube);
  EXPECT_TRUE(r.intersect);
  EXPECT_NEAR(r.distance, 0, 1e-15);
}

// Through the middle along x: the shortest exit is sideways, 1 + radius deep; ties
// go to +y (faces before edges, x before y before z, + before -).
TEST(CapsuleBoxTest, ThroughTheMiddle) {
  const CapsuleBoxResult r = CollideCapsuleBox({{-3, 0, 0}, {3, 0, 0}, 0.25}, kCube);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -1.25);
  EXPECT_EQ(r.normal, Vector3(0, 1, 0));
  EXPECT_TRUE(r.point_box.isApprox(Vector3(-1, 1, 0), 1e-15));
  EXPECT_TRUE(r.point_capsule.isApprox(Vector3(-1, -0.25, 0), 1e-15));
}

// Clipping a vertical edge of the cube diagonally: the exit is along the edge normal
// (1, 1, 0) / sqrt 2, not a face normal.
TEST(CapsuleBoxTest, ClippingAnEdgeExitsAlongEdgeNormal) {
  const CapsuleBoxResult r = CollideCapsuleBox({{1.875, 0, 0.5}, {0, 1.875, 0.5}, 0.125}, kCube);
  EXPECT_TRUE(r.intersect);
  EXPECT_NEAR(r.distance, -(0.125 / std::sqrt(2.0) + 0.125), 1e-15);
  EXPECT_TRUE(r.normal.isApprox(Vector3(1, 1, 0) / std::sqrt(2.0), 1e-15));
  ExpectConsistent({{1.875, 0, 0.5}, {0, 1.875, 0.5}, 0.125}, kCube, r, 1e-12);
}

// A capsule of zero length is a sphere: the same answer as CollideSphereBox.
TEST(CapsuleBoxTest, PointCapsuleMatchesSphereBox) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> coord(-2, 2);
  for (int trial = 0; trial < 2000; ++trial) {
    const Box box = RandomBox(rng);
    const Vector3 c(coord(rng), coord(rng), coord(rng));
    const CapsuleBoxResult r = CollideCapsuleBox({c, c, 0.3}, box);
    const SphereBoxResult s = CollideSphereBox({c, 0.3}, box);
    ASSERT_EQ(r.intersect, s.intersect);
    ASSERT_NEAR(r.distance, s.distance, 1e-13);
    ASSERT_LT((r.normal - s.normal).norm(), 1e-12);
    ASSERT_LT((r.point_box - s.point_box).norm(), 1e-12);
  }
}

// Segments outside the box: distance against the golden-section oracle.
TEST(CapsuleBoxTest, RandomSeparationAgainstOracle) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> coord(-2.5, 2.5);
  std::uniform_real_distribution<double> radius(0, 0.5);
  int checked = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    const Box box = RandomBox(rng);
    const Capsule c{{coord(rng), coord(rng), coord(rng)}, {coord(rng), coord(rng), coord(rng)},
                    radius(rng)};
    const double oracle = OracleSegmentBoxDistance(c.p0, c.p1, box);
    const SegmentBoxClosestPoints closest = FindClosestPointsSegmentBox(c.p0, c.p1, box);
    ASSERT_NEAR(std::sqrt(closest.distance_squared), oracle, 1e-9) << "trial " << trial;
    ASSERT_LT((closest.point_segment - (c.p0 + closest.t * (c.p1 - c.p0))).norm(), 1e-12);
    ASSERT_NEAR((closest.point_segment - closest.point_box).squaredNorm(),
                closest.distance_squared, 1e-12);
    if (oracle < 1e-9) continue;
    const CapsuleBoxResult r = CollideCapsuleBox(c, box);
    ASSERT_NEAR(r.distance, oracle - c.radius, 1e-9) << "trial " << trial;
    if (std::abs(oracle - c.radius) > 1e-9) {
      ASSERT_EQ(r.intersect, oracle < c.radius);
    }
    ExpectConsistent(c, box, r, 1e-10);
    ++checked;
  }
  EXPECT_GT(checked, 700);
}

// Segments inside or through the box: the depth is achieved along the normal and no
// sampled direction exits with less.
TEST(CapsuleBoxTest, RandomPenetrationIsMinimal) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> coord(-1.2, 1.2);
  std::normal_distribution<double> normal;
  int checked = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Box box = RandomBox(rng);
    const Capsule c{box.center + Vector3(coord(rng), coord(rng), coord(rng)),
                    box.center + Vector3(coord(rng), coord(rng), coord(rng)), 0.125};
    if (!SegmentMeetsBox(c.p0, c.p1, box)) continue;
    const CapsuleBoxResult r = CollideCapsuleBox(c, box);
    ASSERT_TRUE(r.intersect);
    const double depth = -r.distance - c.radius;
    ASSERT_GE(depth, -1e-12);
    // Achieved: moving the segment by depth along the normal just clears the box.
    ASSERT_NEAR(ExitDistanceAlong(c.p0, c.p1, box, r.normal), depth, 1e-9) << "trial " << trial;
    // Minimal: no other direction clears it sooner (face normals included).
    for (int k = 0; k < 40; ++k) {
      const Vector3 u = k < 6 ? Vector3(box.rotation.col(k / 2) * (k % 2 ? -1.0 : 1.0))
                              : Vector3(normal(rng), normal(rng), normal(rng)).normalized();
      ASSERT_GE(ExitDistanceAlong(c.p0, c.p1, box, u), depth - 1e-9) << "trial " << trial;
    }
    // The moved capsule touches the box.
    const Capsule moved{c.p0 - r.distance * r.normal, c.p1 - r.distance * r.normal, c.radius};
    ASSERT_NEAR(CollideCapsuleBox(moved, box).distance, 0, 1e-9);
    ExpectConsistent(c, box, r, 1e-10);
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

// Reversing the segment or moving both shapes rigidly leaves the distance unchanged.
TEST(CapsuleBoxTest, Invariances) {
  std::mt19937_64 rng(24);
  std::uniform_real_distribution<double> coord(-2, 2);
  for (int trial = 0; trial < 2000; ++trial) {
    const Box box = RandomBox(rng);
    const Capsule c{{coord(rng), coord(rng), coord(rng)}, {coord(rng), coord(rng), coord(rng)},
                    0.2};
    const CapsuleBoxResult r = CollideCapsuleBox(c, box);
    const CapsuleBoxResult reversed = CollideCapsuleBox({c.p1, c.p0, c.radius}, box);
    ASSERT_NEAR(r.distance, reversed.distance, 1e-12);
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(coord(rng) * 30, coord(rng) * 30, coord(rng) * 30);
    const Capsule moved_capsule{R * c.p0 + t, R * c.p1 + t, c.radius};
    const Box moved_box{R * box.center + t, R * box.rotation, box.half_extents};
    const CapsuleBoxResult moved = CollideCapsuleBox(moved_capsule, moved_box);
    ASSERT_NEAR(r.distance, moved.distance, 1e-11);
    if (r.distance > -c.radius + 1e-9) {
      ASSERT_LT((R * r.normal - moved.normal).norm(), 1e-8);
    }
  }
}

// The answer to non-finite input: no contact, every field zero, so finite.
void ExpectNonFiniteAnswer(const CapsuleBoxResult& r) {
  EXPECT_FALSE(r.intersect);
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_EQ(r.normal, Vector3::Zero());
  EXPECT_EQ(r.point_box, Vector3::Zero());
  EXPECT_EQ(r.point_capsule, Vector3::Zero());
}

// A NaN or infinity in any field of the capsule or the box gives that answer, also
// where the finite shapes overlap (here a capsule from inside the cube).
TEST(CapsuleBoxTest, NonFiniteInputIsNoContact) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Capsule good{{0, 0, 0}, {1, 2, 3}, 1};
  ASSERT_TRUE(CollideCapsuleBox(good, kCube).intersect);
  std::vector<Capsule> bad_capsules = WithOneNonFiniteField(good);
  ASSERT_EQ(bad_capsules.size(), 21u);  // 7 fields (p0, p1, radius) x 3 values
  bad_capsules.push_back({{-inf, 0, 0}, {inf, 0, 0}, 1});
  for (std::size_t i = 0; i < bad_capsules.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "capsule case " << i);
    ExpectNonFiniteAnswer(CollideCapsuleBox(bad_capsules[i], kCube));
  }
  const std::vector<Box> bad_boxes = WithOneNonFiniteField(kCube);
  ASSERT_EQ(bad_boxes.size(), 45u);  // 15 fields (centre, rotation, half extents) x 3 values
  for (std::size_t i = 0; i < bad_boxes.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "box case " << i);
    ExpectNonFiniteAnswer(CollideCapsuleBox(good, bad_boxes[i]));
    ExpectNonFiniteAnswer(CollideCapsuleBox({{nan, 0, 0}, {1, 2, 3}, inf}, bad_boxes[i]));
  }
}

// The segment-box search finds nothing in non-finite input: t 0, points zero, and the
// largest finite squared distance, also for a segment through the cube.
TEST(CapsuleBoxTest, NonFiniteSegmentOrBoxFindsNothing) {
  const auto expect_nothing = [](const SegmentBoxClosestPoints& c) {
    EXPECT_EQ(c.t, 0.0);
    EXPECT_EQ(c.point_segment, Vector3::Zero());
    EXPECT_EQ(c.point_box, Vector3::Zero());
    EXPECT_EQ(c.distance_squared, std::numeric_limits<double>::max());
  };
  const Vector3 p0(0, 0, 0);
  const Vector3 p1(1, 2, 3);
  ASSERT_EQ(FindClosestPointsSegmentBox(p0, p1, kCube).distance_squared, 0.0);
  const std::vector<Vector3> bad_points = WithOneNonFiniteField(p1);
  ASSERT_EQ(bad_points.size(), 9u);  // 3 coordinates x 3 values
  for (std::size_t i = 0; i < bad_points.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "point case " << i);
    expect_nothing(FindClosestPointsSegmentBox(bad_points[i], p1, kCube));
    expect_nothing(FindClosestPointsSegmentBox(p0, bad_points[i], kCube));
  }
  const std::vector<Box> bad_boxes = WithOneNonFiniteField(kCube);
  ASSERT_EQ(bad_boxes.size(), 45u);
  for (std::size_t i = 0; i < bad_boxes.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "box case " << i);
    expect_nothing(FindClosestPointsSegmentBox(p0, p1, bad_boxes[i]));
  }
}

}  // namespace
}  // namespace hapticd::geometry
