// The point-hull distance against an oracle that knows nothing of GJK: outside, the
// nearest point over the hull's boundary triangles; inside, the least depth behind the
// face planes (the boundary of a convex polyhedron is where the first plane is met).
#include "server/geometry/point_hull.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

bool InsideAllPlanes(const ConvexHull& hull, const Vector3& p) {
  for (size_t f = 0; f < hull.faces.size(); ++f) {
    if (hull.face_normals[f].dot(p - hull.vertices[hull.faces[f][0]]) > 0) return false;
  }
  return true;
}

double OracleSignedDistance(const ConvexHull& hull, const Vector3& p) {
  double nearest = kInf, least_depth = kInf;
  for (size_t f = 0; f < hull.faces.size(); ++f) {
    const auto& face = hull.faces[f];
    const Triangle tri{hull.vertices[face[0]], hull.vertices[face[1]], hull.vertices[face[2]]};
    nearest = std::min(nearest, (p - FindClosestPointOnTriangle(p, tri).point).norm());
    least_depth = std::min(least_depth, -hull.face_normals[f].dot(p - tri.v0));
  }
  return InsideAllPlanes(hull, p) ? -least_depth : nearest;
}

TEST(PointHull, OctahedronExactly) {
  std::vector<Vector3> points;
  for (int k = 0; k < 3; ++k) points.push_back(Vector3::Unit(k)), points.push_back(-Vector3::Unit(k));
  const ConvexHull hull = BuildConvexHull(points);
  const double face = 1 / std::sqrt(3.0);
  const PointHullResult out = CalcPointHullDistance(hull, Vector3(1, 1, 1));
  ASSERT_TRUE(out.found);
  EXPECT_NEAR(out.signed_distance, std::sqrt(3.0) - face, 1e-12);
  EXPECT_NEAR((out.normal - Vector3(1, 1, 1).normalized()).norm(), 0, 1e-9);
  EXPECT_NEAR((out.point - Vector3::Constant(1.0 / 3)).norm(), 0, 1e-9);
  const PointHullResult in = CalcPointHullDistance(hull, Vector3(0.1, 0.1, 0.1));
  EXPECT_NEAR(in.signed_distance, 0.3 / std::sqrt(3.0) - face, 1e-12);
  EXPECT_NEAR((in.point - Vector3::Constant(1.0 / 3)).norm(), 0, 1e-12);
  // a vertex is on the boundary
  EXPECT_NEAR(CalcPointHullDistance(hull, Vector3::UnitX()).signed_distance, 0, 1e-15);
}

TEST(PointHull, RandomPointsAgreeWithTheOracle) {
  std::mt19937_64 rng(17);
  int inside = 0, outside = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const ConvexHull hull = BuildConvexHull(RandomBall(rng, 30, 1.0));
    ASSERT_EQ(hull.dimension, 3);
    for (const Vector3& p : RandomBall(rng, 50, 1.6)) {
      const PointHullResult got = CalcPointHullDistance(hull, p);
      ASSERT_TRUE(got.found);
      const double want = OracleSignedDistance(hull, p);
      EXPECT_NEAR(got.signed_distance, want, 1e-9) << p.transpose();
      EXPECT_NEAR(got.normal.norm(), 1, 1e-12);
      // p = point + |d| normal (outside) or point - |d| normal... the same line either way
      EXPECT_NEAR((p - (got.point + got.signed_distance * got.normal)).norm(), 0, 1e-9);
      (want > 0 ? outside : inside) += 1;
    }
  }
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 100);
}

TEST(PointHull, DegenerateInputIsNotFound) {
  std::vector<Vector3> points;
  for (int k = 0; k < 3; ++k) points.push_back(Vector3::Unit(k)), points.push_back(-Vector3::Unit(k));
  const ConvexHull hull = BuildConvexHull(points);
  for (const double bad : {kNan, kInf, -kInf}) {
    for (int axis = 0; axis < 3; ++axis) {
      Vector3 p = Vector3::Zero();
      p[axis] = bad;
      const PointHullResult result = CalcPointHullDistance(hull, p);
      EXPECT_FALSE(result.found);
      EXPECT_EQ(result.signed_distance, 0);
      EXPECT_EQ(result.point, Vector3::Zero());
      EXPECT_EQ(result.normal, Vector3::UnitZ());
    }
  }
  // a flat hull (a square) has no inside to measure
  const std::vector<Vector3> square{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  const ConvexHull flat = BuildConvexHull(square);
  ASSERT_EQ(flat.dimension, 2);
  EXPECT_FALSE(CalcPointHullDistance(flat, Vector3(0.5, 0.5, 1)).found);
}

}  // namespace
}  // namespace hapticd::geometry
