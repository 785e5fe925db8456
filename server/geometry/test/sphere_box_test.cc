#include "server/geometry/sphere_box.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/test/box_surface.h"
#include "server/geometry/test/non_finite.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

// Independent oracle: the distance from the centre to the box surface through the
// closest points of its triangles, and inside/outside from the box coordinates.
double OracleSignedDistance(const Sphere& s, const Box& box) {
  double surface = std::numeric_limits<double>::infinity();
  for (const Triangle& t : FaceTriangles(box)) {
    const double d2 = FindClosestPointOnTriangle(s.center, t).distance_squared;
    surface = std::min(surface, std::sqrt(d2));
  }
  const Vector3 local = box.rotation.transpose() * (s.center - box.center);
  const bool inside = (local.array().abs() <= box.half_extents.array()).all();
  return inside ? -(surface + s.radius) : surface - s.radius;
}

void ExpectConsistent(const Sphere& s, const Box& box, const SphereBoxResult& r, double tol) {
  EXPECT_NEAR(r.normal.norm(), 1.0, 1e-12);
  // point_box in the closed box, point_sphere on the sphere.
  const Vector3 local = box.rotation.transpose() * (r.point_box - box.center);
  EXPECT_TRUE((local.array().abs() <= box.half_extents.array() + tol).all());
  EXPECT_NEAR((r.point_sphere - s.center).norm(), s.radius, tol);
  // point_sphere - point_box = distance * normal.
  EXPECT_LT((r.point_sphere - r.point_box - r.distance * r.normal).norm(), tol);
}

const Box kBox{{0, 0, 0}, Matrix3::Identity(), {1, 2, 3}};

TEST(SphereBoxTest, FaceRegion) {
  const SphereBoxResult r = CollideSphereBox({{3, 0.5, -1}, 1}, kBox);
  EXPECT_FALSE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, 1);
  EXPECT_EQ(r.normal, Vector3(1, 0, 0));
  EXPECT_EQ(r.point_box, Vector3(1, 0.5, -1));
  EXPECT_EQ(r.point_sphere, Vector3(2, 0.5, -1));
}

// Corner region: offset (1, 2, 2) from the corner (1, 2, 3), length 3.
TEST(SphereBoxTest, CornerRegion) {
  const SphereBoxResult r = CollideSphereBox({{2, 4, 5}, 2.5}, kBox);
  EXPECT_FALSE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, 0.5);
  EXPECT_TRUE(r.normal.isApprox(Vector3(1, 2, 2) / 3, 1e-15));
  EXPECT_EQ(r.point_box, Vector3(1, 2, 3));
  // Touching the corner exactly.
  const SphereBoxResult touch = CollideSphereBox({{2, 4, 5}, 3}, kBox);
  EXPECT_TRUE(touch.intersect);
  EXPECT_EQ(touch.distance, 0.0);
  EXPECT_FALSE(CollideSphereBox({{2, 4, 5}, std::nextafter(3.0, 0.0)}, kBox).intersect);
}

// Edge region: offset (0, 3, 4) / 4 from the edge x in [-1, 1], y = -2, z = 3.
TEST(SphereBoxTest, EdgeRegionTouching) {
  const SphereBoxResult r = CollideSphereBox({{0.5, -2.75, 4}, 1.25}, kBox);
  EXPECT_TRUE(r.intersect);
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_TRUE(r.normal.isApprox(Vector3(0, -0.6, 0.8), 1e-15));
  EXPECT_EQ(r.point_box, Vector3(0.5, -2, 3));
}

// Centre inside: exit through the nearest face; the depth adds the radius.
TEST(SphereBoxTest, CentreInsideExitsNearestFace) {
  const SphereBoxResult r = CollideSphereBox({{0.25, -1.5, 0.5}, 0.125}, kBox);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -(0.5 + 0.125));
  EXPECT_EQ(r.normal, Vector3(0, -1, 0));
  EXPECT_EQ(r.point_box, Vector3(0.25, -2, 0.5));
  EXPECT_EQ(r.point_sphere, Vector3(0.25, -1.375, 0.5));
}

// Centre at the box centre: equal depth on both x faces; the + face by convention.
TEST(SphereBoxTest, CentreAtBoxCentre) {
  const SphereBoxResult r = CollideSphereBox({{0, 0, 0}, 0.5}, kBox);
  EXPECT_DOUBLE_EQ(r.distance, -1.5);
  EXPECT_EQ(r.normal, Vector3(1, 0, 0));
}

// Centre on the surface: zero depth to the box, so distance = -radius.
TEST(SphereBoxTest, CentreOnSurface) {
  const SphereBoxResult r = CollideSphereBox({{0.5, 2, 1}, 0.25}, kBox);
  EXPECT_TRUE(r.intersect);
  EXPECT_DOUBLE_EQ(r.distance, -0.25);
  EXPECT_EQ(r.normal, Vector3(0, 1, 0));
}

// A flat box (zero thickness) and a point sphere on it.
TEST(SphereBoxTest, DegenerateBoxAndPointSphere) {
  const Box flat{{0, 0, 0}, Matrix3::Identity(), {1, 1, 0}};
  EXPECT_TRUE(CollideSphereBox({{0.5, 0.5, 0}, 0}, flat).intersect);
  EXPECT_FALSE(CollideSphereBox({{0.5, 0.5, 0.25}, 0}, flat).intersect);
  EXPECT_DOUBLE_EQ(CollideSphereBox({{0.5, 0.5, -0.25}, 0}, flat).distance, 0.25);
  EXPECT_TRUE(CollideSphereBox({{0.5, 0.5, 0.25}, 0.25}, flat).intersect);
}

// Random rotated boxes and spheres against the triangle oracle.
TEST(SphereBoxTest, RandomAgainstTriangleOracle) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> extent(0, 1.5);
  std::uniform_real_distribution<double> radius(0, 1);
  int inside = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const Box box{{coord(rng), coord(rng), coord(rng)}, RandomRotation(rng),
                  {extent(rng), extent(rng), extent(rng)}};
    const Sphere s{box.center + Vector3(coord(rng), coord(rng), coord(rng)), radius(rng)};
    const SphereBoxResult r = CollideSphereBox(s, box);
    const double expected = OracleSignedDistance(s, box);
    ASSERT_NEAR(r.distance, expected, 1e-12) << "trial " << trial;
    if (std::abs(expected) > 1e-12) {
      ASSERT_EQ(r.intersect, expected < 0);
    }
    inside += r.distance < -s.radius;
    ExpectConsistent(s, box, r, 1e-12);
  }
  EXPECT_GT(inside, 100);
}

// The normal points along the shortest exit: moving the sphere by -distance along it
// leaves the sphere touching the box, whichever side it started from.
TEST(SphereBoxTest, MovingAlongNormalMakesContact) {
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> extent(0.1, 1.5);
  std::uniform_real_distribution<double> radius(0, 1);
  for (int trial = 0; trial < 2000; ++trial) {
    const Box box{{0, 0, 0}, RandomRotation(rng), {extent(rng), extent(rng), extent(rng)}};
    const Sphere s{{coord(rng), coord(rng), coord(rng)}, radius(rng)};
    const SphereBoxResult r = CollideSphereBox(s, box);
    const Sphere moved{s.center - r.distance * r.normal, s.radius};
    EXPECT_NEAR(CollideSphereBox(moved, box).distance, 0, 1e-12);
    EXPECT_NEAR(OracleSignedDistance(moved, box), 0, 1e-12);
  }
}

// A rigid motion of both shapes moves the answer with them.
TEST(SphereBoxTest, RigidMotionInvariance) {
  std::mt19937_64 rng(44);
  std::uniform_real_distribution<double> coord(-2, 2);
  std::uniform_real_distribution<double> extent(0.1, 1.5);
  for (int trial = 0; trial < 1000; ++trial) {
    const Box box{{coord(rng), coord(rng), coord(rng)}, RandomRotation(rng),
                  {extent(rng), extent(rng), extent(rng)}};
    const Sphere s{{coord(rng), coord(rng), coord(rng)}, 0.5};
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(coord(rng) * 50, coord(rng) * 50, coord(rng) * 50);
    const Box moved_box{R * box.center + t, R * box.rotation, box.half_extents};
    const Sphere moved_s{R * s.center + t, s.radius};
    const SphereBoxResult a = CollideSphereBox(s, box);
    const SphereBoxResult b = CollideSphereBox(moved_s, moved_box);
    EXPECT_NEAR(a.distance, b.distance, 1e-11);
    EXPECT_LT((R * a.normal - b.normal).norm(), 1e-9);
    EXPECT_LT((R * a.point_box + t - b.point_box).norm(), 1e-10);
  }
}

// The answer to non-finite input: no contact, every field zero, so finite.
void ExpectNonFiniteAnswer(const SphereBoxResult& r) {
  EXPECT_FALSE(r.intersect);
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_EQ(r.normal, Vector3::Zero());
  EXPECT_EQ(r.point_box, Vector3::Zero());
  EXPECT_EQ(r.point_sphere, Vector3::Zero());
}

// A NaN or infinity in any field of the sphere or the box gives that answer, also
// where the finite shapes overlap (here a sphere centred on a corner of the box).
TEST(SphereBoxTest, NonFiniteInputIsNoContact) {
  const double inf = std::numeric_limits<double>::infinity();
  const Sphere good{{1, 2, 3}, 1};
  ASSERT_TRUE(CollideSphereBox(good, kBox).intersect);
  std::vector<Sphere> bad_spheres = WithOneNonFiniteField(good);
  ASSERT_EQ(bad_spheres.size(), 12u);  // 4 fields (centre, radius) x 3 values
  bad_spheres.push_back({{-inf, inf, 0}, inf});
  for (std::size_t i = 0; i < bad_spheres.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "sphere case " << i);
    ExpectNonFiniteAnswer(CollideSphereBox(bad_spheres[i], kBox));
  }
  const std::vector<Box> bad_boxes = WithOneNonFiniteField(kBox);
  ASSERT_EQ(bad_boxes.size(), 45u);  // 15 fields (centre, rotation, half extents) x 3 values
  for (std::size_t i = 0; i < bad_boxes.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << "box case " << i);
    ExpectNonFiniteAnswer(CollideSphereBox(good, bad_boxes[i]));
  }
}

}  // namespace
}  // namespace hapticd::geometry
