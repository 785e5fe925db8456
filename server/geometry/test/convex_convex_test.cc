#include "server/geometry/convex_convex.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/test/minkowski_oracle.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

std::vector<Vector3> Cube(const Vector3& lo, const Vector3& hi) {
  std::vector<Vector3> corners;
  for (int i = 0; i < 8; ++i) corners.push_back(Vector3(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()));
  return corners;
}

std::vector<Vector3> Moved(const std::vector<Vector3>& points, const Matrix3& R, const Vector3& t) {
  std::vector<Vector3> out;
  for (const Vector3& p : points) out.push_back(R * p + t);
  return out;
}

void ExpectTouching(const std::vector<Vector3>& a, const std::vector<Vector3>& b, const Vector3& normal) {
  const ConvexConvexResult r = CollideConvex(a, b);
  EXPECT_TRUE(r.intersect);
  EXPECT_EQ(r.distance, 0);
  if (normal != Vector3::Zero()) {
    EXPECT_NEAR((r.normal - normal).norm(), 0, 1e-15);
  }
  EXPECT_NEAR((r.point_a - r.point_b).norm(), 0, 1e-15);
}

TEST(CollideConvex, TouchingHullsIntersectAtDistanceZero) {
  const auto a = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  // face, edge and corner contact
  ExpectTouching(a, Cube(Vector3(1, 0.25, 0.5), Vector3(2, 1.25, 1.5)), Vector3::UnitX());
  ExpectTouching(a, Cube(Vector3(1, 1, 0.5), Vector3(2, 2, 1.5)), Vector3::Zero());
  ExpectTouching(a, Cube(Vector3(1, 1, 1), Vector3(2, 2, 2)), Vector3::Zero());
  // a vertex on a tilted face: x + y + z = 1 holds exactly at (0.25, 0.25, 0.5)
  const std::vector<Vector3> corner = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(0, 1, 0), Vector3(0, 0, 1)};
  const std::vector<Vector3> spike = {Vector3(0.25, 0.25, 0.5), Vector3(2, 1, 1), Vector3(1, 2, 1), Vector3(1, 1, 2)};
  ExpectTouching(corner, spike, Vector3(1, 1, 1).normalized());
  // crossed edges: a's top ridge along x, b's bottom ridge along y, both at z = 0
  const std::vector<Vector3> ridge_x = {Vector3(-1, 0, 0), Vector3(1, 0, 0), Vector3(0, -1, -1), Vector3(0, 1, -1)};
  const std::vector<Vector3> ridge_y = {Vector3(0, -1, 0), Vector3(0, 1, 0), Vector3(-1, 0, 1), Vector3(1, 0, 1)};
  ExpectTouching(ridge_x, ridge_y, Vector3::UnitZ());
}

TEST(CollideConvex, NearMissAndNearHitKeepTheirSign) {
  const auto a = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  const double eps = std::ldexp(1.0, -30);
  const ConvexConvexResult gap = CollideConvex(a, Cube(Vector3(1 + eps, 0.5, 0.5), Vector3(2, 1.5, 1.5)));
  EXPECT_FALSE(gap.intersect);
  EXPECT_NEAR(gap.distance, eps, 1e-24);
  const ConvexConvexResult hit = CollideConvex(a, Cube(Vector3(1 - eps, 0.5, 0.5), Vector3(2, 1.5, 1.5)));
  EXPECT_TRUE(hit.intersect);
  EXPECT_NEAR(hit.distance, -eps, 1e-24);
  EXPECT_NEAR((hit.normal - Vector3::UnitX()).norm(), 0, 1e-15);
  // far from the origin the same gap (relative to the coordinates) still shows
  const Vector3 far(1000, -2000, 500);
  const ConvexConvexResult far_gap = CollideConvex(Moved(a, Matrix3::Identity(), far),
                                                   Moved(Cube(Vector3(1 + 1e-6, 0, 0), Vector3(2, 1, 1)),
                                                         Matrix3::Identity(), far));
  EXPECT_FALSE(far_gap.intersect);
  EXPECT_NEAR(far_gap.distance, 1e-6, 1e-12);
}

// Exactly representable integer hulls, many of them flat, touching or just apart;
// the oracle asks whether the origin is in the hull of the (exact) differences.
TEST(CollideConvex, ExactIntersectionOnIntegerHulls) {
  std::mt19937_64 rng(61);
  std::uniform_int_distribution<int> coord(-3, 3), shift(-3, 3), count(1, 7);
  int touching = 0, apart = 0, overlapping = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    std::vector<Vector3> a, b;
    for (int i = count(rng); i > 0; --i) a.push_back(Vector3(coord(rng), coord(rng), coord(rng)));
    const Vector3 t(shift(rng), shift(rng), shift(rng));
    for (int i = count(rng); i > 0; --i) b.push_back(t + Vector3(coord(rng), coord(rng), coord(rng)));
    const ConvexHull d = BuildConvexHull(MinkowskiDifference(a, b));
    const ConvexHull origin = BuildConvexHull(std::vector<Vector3>{Vector3::Zero()});
    // origin in D, exactly (D's own exact test; independent of a's and b's features)
    const bool oracle = HullsIntersect(d, origin);
    const ConvexConvexResult r = CollideConvex(a, b);
    ASSERT_EQ(r.intersect, oracle) << trial;
    EXPECT_EQ(HullsIntersect(BuildConvexHull(a), BuildConvexHull(b)), oracle) << trial;
    // touching: the origin on D's boundary (exactly)
    bool on_boundary = d.dimension < 3;
    for (const auto& f : d.faces) {
      on_boundary = on_boundary || Orient3d(d.vertices[f[0]], d.vertices[f[1]], d.vertices[f[2]], Vector3::Zero()) == 0;
    }
    const double signed_distance = OracleSignedDistance(a, b);
    if (oracle && on_boundary) {
      ++touching;
      EXPECT_EQ(r.distance, 0) << trial;
    } else if (oracle) {
      ++overlapping;
    } else {
      ++apart;
      EXPECT_GT(r.distance, 0) << trial;
    }
    if (!std::isnan(signed_distance)) {
      EXPECT_NEAR(r.distance, signed_distance, 1e-12) << trial;
    }
  }
  EXPECT_GT(touching, 100) << touching << " " << apart << " " << overlapping;
  EXPECT_GT(apart, 300);
  EXPECT_GT(overlapping, 300);
}

TEST(CollideConvex, MatchesTheSignedDistanceOracle) {
  std::mt19937_64 rng(62);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 400; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 4 + trial % 30, 0.2 + u(rng), Vector3::Zero());
    const Vector3 offset(2.5 * u(rng), u(rng) - 0.5, u(rng) - 0.5);
    const std::vector<Vector3> b = RandomBall(rng, 4 + (trial * 7) % 30, 0.2 + u(rng), offset);
    const double oracle = OracleSignedDistance(a, b);
    const ConvexConvexResult r = CollideConvex(a, b);
    EXPECT_EQ(r.intersect, oracle <= 0) << trial;
    EXPECT_NEAR(r.distance, oracle, 1e-12) << trial;
    EXPECT_NEAR(r.normal.norm(), 1, 1e-15);
    EXPECT_NEAR((r.point_b - r.point_a - r.distance * r.normal).norm(), 0, 1e-12) << trial;
    // swapping flips the normal; a rigid motion of both changes nothing
    const ConvexConvexResult ba = CollideConvex(b, a);
    EXPECT_EQ(ba.intersect, r.intersect);
    EXPECT_NEAR(ba.distance, r.distance, 1e-13);
    EXPECT_NEAR((ba.normal + r.normal).norm(), 0, 1e-9) << trial;
    const Matrix3 R = Eigen::AngleAxisd(0.1 * trial, Vector3(1, 2, 3).normalized()).toRotationMatrix();
    const Vector3 t(5, -7, 3);
    const ConvexConvexResult moved = CollideConvex(Moved(a, R, t), Moved(b, R, t));
    EXPECT_EQ(moved.intersect, r.intersect);
    EXPECT_NEAR(moved.distance, r.distance, 1e-12);
    EXPECT_NEAR((moved.normal - R * r.normal).norm(), 0, 1e-9) << trial;
  }
}

TEST(CollideConvex, DegeneratePointSets) {
  const std::vector<Vector3> p = {Vector3(1, 2, 3)};
  ExpectTouching(p, p, Vector3::Zero());
  const ConvexConvexResult apart = CollideConvex(p, {Vector3(1, 2, 5)});
  EXPECT_FALSE(apart.intersect);
  EXPECT_EQ(apart.distance, 2);
  EXPECT_EQ(apart.normal, Vector3::UnitZ());
  // crossing segments, collinear overlapping segments, a point on a segment
  ExpectTouching({Vector3(-1, 0, 0), Vector3(1, 0, 0)}, {Vector3(0, -1, 0), Vector3(0, 1, 0)}, Vector3::Zero());
  ExpectTouching({Vector3(0, 0, 0), Vector3(2, 0, 0)}, {Vector3(1, 0, 0), Vector3(3, 0, 0)}, Vector3::Zero());
  ExpectTouching({Vector3(0, 0, 0), Vector3(2, 2, 2)}, {Vector3(0.5, 0.5, 0.5)}, Vector3::Zero());
  // overlapping squares in one plane: depth 0, normal across the plane
  const std::vector<Vector3> s1 = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(0, 1, 0), Vector3(1, 1, 0)};
  const std::vector<Vector3> s2 = {Vector3(0.5, 0.5, 0), Vector3(2, 0.5, 0), Vector3(0.5, 2, 0), Vector3(2, 2, 0)};
  const ConvexConvexResult flat = CollideConvex(s1, s2);
  EXPECT_TRUE(flat.intersect);
  EXPECT_EQ(flat.distance, 0);
  EXPECT_NEAR(std::abs(flat.normal.z()), 1, 1e-15);
  // parallel squares 0.5 apart
  const ConvexConvexResult stacked = CollideConvex(s1, Moved(s1, Matrix3::Identity(), Vector3(0.25, 0.25, 0.5)));
  EXPECT_FALSE(stacked.intersect);
  EXPECT_NEAR(stacked.distance, 0.5, 1e-15);
  // a square through a cube's face
  const auto cube = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  const ConvexConvexResult plate = CollideConvex(cube, Moved(s1, Matrix3::Identity(), Vector3(0.25, 0.25, 0.875)));
  EXPECT_TRUE(plate.intersect);
  EXPECT_NEAR(plate.distance, -0.125, 1e-15);
}

TEST(CollideConvex, NonFiniteInputGivesNaNWithoutCrashing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto cube = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  const ConvexConvexResult r = CollideConvex(cube, {Vector3(nan, 0, 0), Vector3(1, 1, 1)});
  EXPECT_FALSE(r.intersect);
  EXPECT_TRUE(std::isnan(r.distance));
  const ConvexConvexResult inf = CollideConvex({Vector3(std::numeric_limits<double>::infinity(), 0, 0)}, cube);
  EXPECT_FALSE(inf.intersect);
  EXPECT_TRUE(std::isnan(CollideConvex({}, cube).distance));
  EXPECT_TRUE(ValidatePointSet(std::vector{Vector3(nan, 0, 0)}, "b").has_value());
}

}  // namespace
}  // namespace hapticd::geometry
