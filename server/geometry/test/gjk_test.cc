#include "server/geometry/gjk.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/convex_hull.h"
#include "server/geometry/test/minkowski_oracle.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

// Largest signed distance of p beyond the hull's face planes (<= 0: inside).
double Outside(const ConvexHull& h, const Vector3& p) {
  double out = -std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < h.faces.size(); ++f) out = std::max(out, h.face_normals[f].dot(p - h.vertices[h.faces[f][0]]));
  return out;
}

GjkResult Distance(const std::vector<Vector3>& a, const std::vector<Vector3>& b) {
  return CalcGjkDistance(PointSetSupport(a), PointSetSupport(b));
}

TEST(Gjk, CubesApartAlongX) {
  std::vector<Vector3> a, b;
  for (int i = 0; i < 8; ++i) {
    const Vector3 corner(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    a.push_back(corner);
    b.push_back(corner + Vector3(1.5, 0.25, -0.5));
  }
  const GjkResult r = Distance(a, b);
  EXPECT_FALSE(r.intersect);
  EXPECT_NEAR(r.distance, 0.5, 1e-15);
  EXPECT_NEAR((r.normal - Vector3::UnitX()).norm(), 0, 1e-15);
  EXPECT_NEAR(r.point_a.x(), 1, 1e-15);
  EXPECT_NEAR(r.point_b.x(), 1.5, 1e-15);
  EXPECT_NEAR((r.point_b - r.point_a - r.distance * r.normal).norm(), 0, 1e-15);
}

TEST(Gjk, VertexToVertexAndSkewSegments) {
  const std::vector<Vector3> a = {Vector3(0, 0, 0), Vector3(-1, 0, 0), Vector3(0, -1, 0), Vector3(0, 0, -1)};
  const std::vector<Vector3> b = {Vector3(1, 1, 1), Vector3(2, 1, 1), Vector3(1, 2, 1), Vector3(1, 1, 2)};
  const GjkResult r = Distance(a, b);
  EXPECT_NEAR(r.distance, std::sqrt(3.0), 1e-15);
  EXPECT_NEAR((r.normal - Vector3(1, 1, 1).normalized()).norm(), 0, 1e-15);
  EXPECT_NEAR((r.point_a - Vector3::Zero()).norm(), 0, 1e-15);
  EXPECT_NEAR((r.point_b - Vector3(1, 1, 1)).norm(), 0, 1e-15);

  // skew segments: the common perpendicular is the z axis at the origin
  const std::vector<Vector3> s = {Vector3(-1, 0, 0), Vector3(1, 0, 0)};
  const std::vector<Vector3> t = {Vector3(0, -1, 1), Vector3(0, 3, 1)};
  const GjkResult st = Distance(s, t);
  EXPECT_NEAR(st.distance, 1, 1e-15);
  EXPECT_NEAR((st.normal - Vector3::UnitZ()).norm(), 0, 1e-15);
  EXPECT_NEAR(st.point_a.norm(), 0, 1e-15);
  EXPECT_NEAR((st.point_b - Vector3(0, 0, 1)).norm(), 0, 1e-15);
}

TEST(Gjk, PointAgainstAPolygonAndAPoint) {
  const std::vector<Vector3> tri = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(0, 1, 0)};
  const GjkResult above = Distance(tri, {Vector3(0.25, 0.25, -2)});
  EXPECT_NEAR(above.distance, 2, 1e-15);
  EXPECT_NEAR((above.normal + Vector3::UnitZ()).norm(), 0, 1e-15);
  const GjkResult beside = Distance(tri, {Vector3(2, 2, 0)});
  EXPECT_NEAR(beside.distance, std::sqrt(4.5), 1e-15);
  const GjkResult points = Distance({Vector3(1, 2, 3)}, {Vector3(1, 2, 7)});
  EXPECT_EQ(points.distance, 4);
  EXPECT_TRUE(Distance({Vector3(1, 2, 3)}, {Vector3(1, 2, 3)}).intersect);
}

TEST(Gjk, MatchesTheMinkowskiDifferenceOracle) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(0, 1);
  int separated = 0, overlapping = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 4 + trial % 25, 0.2 + u(rng), Vector3::Zero());
    const Vector3 offset = 3 * u(rng) * RandomRotation(rng).col(0);
    const std::vector<Vector3> b = RandomBall(rng, 4 + (trial * 7) % 25, 0.2 + u(rng), offset);
    const double oracle = OracleSignedDistance(a, b);
    const GjkResult r = Distance(a, b);
    const double size = 2.5;
    if (oracle > 1e-9) {
      ++separated;
      ASSERT_FALSE(r.intersect) << trial;
      EXPECT_NEAR(r.distance, oracle, 1e-12 * size) << trial;
      // witnesses on the hulls, joined by distance * normal
      EXPECT_NEAR((r.point_b - r.point_a - r.distance * r.normal).norm(), 0, 1e-12 * size);
      EXPECT_LE(Outside(BuildConvexHull(a), r.point_a), 1e-12 * size);
      EXPECT_LE(Outside(BuildConvexHull(b), r.point_b), 1e-12 * size);
      EXPECT_LT(r.iterations, 30);
    } else if (oracle < -1e-9) {
      ++overlapping;
      EXPECT_TRUE(r.intersect) << trial;
      EXPECT_EQ(r.distance, 0);
    }
  }
  EXPECT_GT(separated, 100);
  EXPECT_GT(overlapping, 100);
}

TEST(Gjk, SwappingFlipsTheNormalAndRigidMotionChangesNothing) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 12, 0.5, Vector3::Zero());
    const std::vector<Vector3> b = RandomBall(rng, 9, 0.5, Vector3(1.5, u(rng), u(rng)));
    const GjkResult ab = Distance(a, b), ba = Distance(b, a);
    EXPECT_NEAR(ab.distance, ba.distance, 1e-14);
    EXPECT_NEAR((ab.normal + ba.normal).norm(), 0, 1e-9);
    // move both by one rigid motion
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(10 * u(rng), 10 * u(rng), 10 * u(rng));
    std::vector<Vector3> ma, mb;
    for (const Vector3& p : a) ma.push_back(R * p + t);
    for (const Vector3& p : b) mb.push_back(R * p + t);
    const GjkResult moved = Distance(ma, mb);
    EXPECT_NEAR(moved.distance, ab.distance, 1e-13);
    EXPECT_NEAR((moved.normal - R * ab.normal).norm(), 0, 1e-9);
    EXPECT_NEAR((moved.point_a - (R * ab.point_a + t)).norm(), 0, 1e-9);
  }
}

TEST(Gjk, HullSupportWithAPoseEqualsMovedPoints) {
  std::mt19937_64 rng(23);
  const std::vector<Vector3> a = RandomBall(rng, 50, 1, Vector3::Zero());
  const std::vector<Vector3> b = RandomBall(rng, 50, 1, Vector3::Zero());
  const ConvexHull ha = BuildConvexHull(a), hb = BuildConvexHull(b);
  for (int trial = 0; trial < 50; ++trial) {
    const Matrix3 Ra = RandomRotation(rng), Rb = RandomRotation(rng);
    const Vector3 pa(0.1 * trial, 0, 0), pb(3, 0.05 * trial, 0);
    std::vector<Vector3> ma, mb;
    for (const Vector3& p : a) ma.push_back(Ra * p + pa);
    for (const Vector3& p : b) mb.push_back(Rb * p + pb);
    const GjkResult posed = CalcGjkDistance(HullSupport(ha, Ra, pa), HullSupport(hb, Rb, pb));
    EXPECT_NEAR(posed.distance, Distance(ma, mb).distance, 1e-13);
  }
}

TEST(Gjk, WarmStartFromTheFinalSimplexGivesTheSameAnswerAtOnce) {
  std::mt19937_64 rng(24);
  const ConvexHull a = BuildConvexHull(RandomBall(rng, 40, 1, Vector3::Zero()));
  const ConvexHull b = BuildConvexHull(RandomBall(rng, 40, 1, Vector3(2.5, 0.5, 0)));
  const GjkResult cold = CalcGjkDistance(HullSupport(a), HullSupport(b));
  ASSERT_GT(cold.simplex.size, 0);
  const GjkResult warm = CalcGjkDistance(HullSupport(a), HullSupport(b), &cold.simplex);
  EXPECT_NEAR(warm.distance, cold.distance, 1e-14);
  EXPECT_LE(warm.iterations, 1);
  EXPECT_LT(warm.support_visits, cold.support_visits);
}

TEST(Gjk, PrimitiveAdapters) {
  // spheres: |c_b - c_a| - r_a - r_b
  const Sphere s1{Vector3(0, 0, 0), 0.5}, s2{Vector3(2, 1, -1), 0.25};
  const GjkResult spheres = CalcGjkDistance(SphereSupport(s1), SphereSupport(s2));
  EXPECT_NEAR(spheres.distance, std::sqrt(6.0) - 0.75, 1e-9);
  EXPECT_NEAR((spheres.normal - Vector3(2, 1, -1).normalized()).norm(), 0, 1e-6);
  // boxes, one rotated 90 degrees about z (the same footprint)
  Box b1, b2;
  b1.half_extents = Vector3(1, 0.5, 0.25);
  b2.center = Vector3(0, 3, 0);
  b2.rotation = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitZ()).toRotationMatrix();
  b2.half_extents = Vector3(1, 0.5, 0.25);
  const GjkResult boxes = CalcGjkDistance(BoxSupport(b1), BoxSupport(b2));
  EXPECT_NEAR(boxes.distance, 1.5, 1e-12);
  EXPECT_GT(boxes.simplex.size, 0);
  // capsule along x above a sphere
  const Capsule c{Vector3(-1, 0, 2), Vector3(1, 0, 2), 0.5};
  const GjkResult capsule = CalcGjkDistance(SphereSupport(s1), CapsuleSupport(c));
  EXPECT_NEAR(capsule.distance, 1.0, 1e-9);
  EXPECT_NEAR((capsule.normal - Vector3::UnitZ()).norm(), 0, 1e-6);
  // overlapping box and sphere
  EXPECT_TRUE(CalcGjkDistance(BoxSupport(b1), SphereSupport(Sphere{Vector3(1.2, 0, 0), 0.5})).intersect);
}

TEST(Gjk, NonFiniteInputEndsWithoutCrashing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Vector3> a = {Vector3(0, 0, 0), Vector3(1, nan, 0), Vector3(0, 1, 0)};
  const std::vector<Vector3> b = {Vector3(3, 0, 0), Vector3(4, 1, 0)};
  const GjkResult r = Distance(a, b);
  EXPECT_LE(r.iterations, GjkOptions{}.max_iterations);
  const std::vector<Vector3> inf = {Vector3(std::numeric_limits<double>::infinity(), 0, 0)};
  EXPECT_LE(Distance(inf, b).iterations, GjkOptions{}.max_iterations);
  const GjkResult spheres = CalcGjkDistance(SphereSupport(Sphere{Vector3(nan, 0, 0), 1}), SphereSupport(Sphere{}));
  EXPECT_LE(spheres.iterations, GjkOptions{}.max_iterations);
}

}  // namespace
}  // namespace hapticd::geometry
