#include "server/geometry/penetration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/convex_convex.h"
#include "server/geometry/convex_hull.h"
#include "server/geometry/test/minkowski_oracle.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

std::vector<Vector3> Cube(const Vector3& lo, const Vector3& hi) {
  std::vector<Vector3> corners;
  for (int i = 0; i < 8; ++i) corners.push_back(Vector3(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()));
  return corners;
}

// Oracle: inside the hull of the Minkowski difference {b_j - a_i}, the depth is the
// least distance from the origin to a face plane, along that face's normal.
struct Oracle {
  double depth;
  Vector3 normal;
};
Oracle OracleDepth(const std::vector<Vector3>& a, const std::vector<Vector3>& b) {
  const ConvexHull d = BuildConvexHull(MinkowskiDifference(a, b));
  Oracle best{std::numeric_limits<double>::infinity(), Vector3::Zero()};
  for (size_t f = 0; f < d.faces.size(); ++f) {
    const double plane = d.face_normals[f].dot(d.vertices[d.faces[f][0]]);
    // the face of D with outward normal m is the translation direction -m for b
    if (plane < best.depth) best = {plane, -d.face_normals[f]};
  }
  return best;
}

double Outside(const ConvexHull& h, const Vector3& p) {
  double out = -std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < h.faces.size(); ++f) out = std::max(out, h.face_normals[f].dot(p - h.vertices[h.faces[f][0]]));
  return out;
}

TEST(Penetration, OverlappingCubesSeparateAlongTheShallowAxis) {
  const auto a = Cube(Vector3(0, 0, 0), Vector3(1, 1, 1));
  const auto b = Cube(Vector3(0.75, 0.25, -0.5), Vector3(1.75, 1.25, 0.5));
  const PenetrationResult r = CalcPenetration(BuildConvexHull(a), BuildConvexHull(b));
  EXPECT_DOUBLE_EQ(r.depth, 0.25);
  EXPECT_NEAR((r.normal - Vector3::UnitX()).norm(), 0, 1e-15);
  EXPECT_NEAR((r.point_a - r.point_b - r.depth * r.normal).norm(), 0, 1e-15);
  EXPECT_DOUBLE_EQ(r.point_a.x(), 1);
  EXPECT_DOUBLE_EQ(r.point_b.x(), 0.75);
}

TEST(Penetration, EdgeIntoEdge) {
  // a wedge with its ridge up along x, and one with its ridge down along y, 0.25 lower:
  // the depth is along the ridges' common perpendicular (z)
  const std::vector<Vector3> a = {Vector3(-2, -1, 0), Vector3(-2, 1, 0), Vector3(-2, 0, 1),
                                  Vector3(2, -1, 0),  Vector3(2, 1, 0),  Vector3(2, 0, 1)};
  const std::vector<Vector3> b = {Vector3(-1, -2, 1.75), Vector3(1, -2, 1.75), Vector3(0, -2, 0.75),
                                  Vector3(-1, 2, 1.75),  Vector3(1, 2, 1.75),  Vector3(0, 2, 0.75)};
  const PenetrationResult r = CalcPenetration(BuildConvexHull(a), BuildConvexHull(b));
  EXPECT_NEAR(r.depth, 0.25, 1e-15);
  EXPECT_NEAR((r.normal - Vector3::UnitZ()).norm(), 0, 1e-15);
  EXPECT_NEAR((r.point_a - Vector3(0, 0, 1)).norm(), 0, 1e-15);
  EXPECT_NEAR((r.point_b - Vector3(0, 0, 0.75)).norm(), 0, 1e-15);
}

TEST(Penetration, MatchesTheMinkowskiDifferenceOracle) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0, 1);
  int tested = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 4 + trial % 25, 0.3 + u(rng), Vector3::Zero());
    const Vector3 offset = u(rng) * RandomRotation(rng).col(0);
    const std::vector<Vector3> b = RandomBall(rng, 4 + (trial * 5) % 25, 0.3 + u(rng), offset);
    const Oracle oracle = OracleDepth(a, b);
    if (oracle.depth < 1e-9) continue;
    ++tested;
    const ConvexHull ha = BuildConvexHull(a), hb = BuildConvexHull(b);
    const PenetrationResult r = CalcPenetration(ha, hb);
    EXPECT_NEAR(r.depth, oracle.depth, 1e-12) << trial;
    EXPECT_NEAR((r.normal - oracle.normal).norm(), 0, 1e-9) << trial;
    // witnesses on the hulls, joined by depth * normal
    EXPECT_NEAR((r.point_a - r.point_b - r.depth * r.normal).norm(), 0, 1e-12);
    EXPECT_LE(Outside(ha, r.point_a), 1e-12);
    EXPECT_LE(Outside(hb, r.point_b), 1e-12);
    // translating b by depth * normal leaves the hulls just touching
    std::vector<Vector3> moved;
    for (const Vector3& p : b) moved.push_back(p + r.depth * r.normal);
    EXPECT_NEAR(CollideConvex(a, moved).distance, 0, 1e-12) << trial;
  }
  EXPECT_GT(tested, 200);
}

TEST(Penetration, SwappingFlipsTheNormalAndRigidMotionChangesNothing) {
  std::mt19937_64 rng(32);
  for (int trial = 0; trial < 100; ++trial) {
    const std::vector<Vector3> a = RandomBall(rng, 15, 1, Vector3::Zero());
    const std::vector<Vector3> b = RandomBall(rng, 15, 1, Vector3(0.5, 0, 0));
    const ConvexHull ha = BuildConvexHull(a), hb = BuildConvexHull(b);
    const PenetrationResult ab = CalcPenetration(ha, hb), ba = CalcPenetration(hb, ha);
    EXPECT_NEAR(ab.depth, ba.depth, 1e-14);
    EXPECT_NEAR((ab.normal + ba.normal).norm(), 0, 1e-9);
    const Matrix3 R = RandomRotation(rng);
    const Vector3 t(-3, 7, 2);
    std::vector<Vector3> ma, mb;
    for (const Vector3& p : a) ma.push_back(R * p + t);
    for (const Vector3& p : b) mb.push_back(R * p + t);
    const PenetrationResult moved = CalcPenetration(BuildConvexHull(ma), BuildConvexHull(mb));
    EXPECT_NEAR(moved.depth, ab.depth, 1e-13);
    EXPECT_NEAR((moved.normal - R * ab.normal).norm(), 0, 1e-9);
  }
}

TEST(Penetration, LowerDimensionalHulls) {
  const ConvexHull cube = BuildConvexHull(Cube(Vector3(0, 0, 0), Vector3(1, 1, 1)));
  // a point inside: the nearest face
  const PenetrationResult point = CalcPenetration(cube, BuildConvexHull(std::vector{Vector3(0.5, 0.875, 0.25)}));
  EXPECT_DOUBLE_EQ(point.depth, 0.125);
  EXPECT_NEAR((point.normal - Vector3::UnitY()).norm(), 0, 1e-15);
  // a plate (in the plane x = 0.5) poking 0.25 into the cube's top
  const std::vector<Vector3> plate = {Vector3(0.5, 0.25, 0.75), Vector3(0.5, 0.75, 0.75), Vector3(0.5, 0.25, 3),
                                      Vector3(0.5, 0.75, 3)};
  const PenetrationResult r = CalcPenetration(cube, BuildConvexHull(plate));
  EXPECT_DOUBLE_EQ(r.depth, 0.25);
  EXPECT_NEAR((r.normal - Vector3::UnitZ()).norm(), 0, 1e-15);
  // a segment through the cube along x, off centre: out through the nearest side
  const std::vector<Vector3> rod = {Vector3(-1, 0.375, 0.5), Vector3(2, 0.375, 0.5)};
  const PenetrationResult s = CalcPenetration(cube, BuildConvexHull(rod));
  EXPECT_DOUBLE_EQ(s.depth, 0.375);
  EXPECT_NEAR((s.normal + Vector3::UnitY()).norm(), 0, 1e-15);
  // two crossing segments touch: depth 0 along their common normal
  const std::vector<Vector3> s1 = {Vector3(-1, 0, 0), Vector3(1, 0, 0)}, s2 = {Vector3(0, -1, 0), Vector3(0, 1, 0)};
  const PenetrationResult cross = CalcPenetration(BuildConvexHull(s1), BuildConvexHull(s2));
  EXPECT_EQ(cross.depth, 0);
  EXPECT_NEAR(std::abs(cross.normal.z()), 1, 1e-15);
  // equal points: depth 0
  const ConvexHull p = BuildConvexHull(std::vector{Vector3(1, 2, 3)});
  EXPECT_EQ(CalcPenetration(p, p).depth, 0);
}

TEST(Penetration, NonFiniteOrEmptyHullsGiveNaN) {
  const ConvexHull cube = BuildConvexHull(Cube(Vector3(0, 0, 0), Vector3(1, 1, 1)));
  const ConvexHull bad = BuildConvexHull(std::vector{Vector3(std::numeric_limits<double>::quiet_NaN(), 0, 0)});
  EXPECT_TRUE(std::isnan(CalcPenetration(cube, bad).depth));
  EXPECT_TRUE(std::isnan(CalcPenetration(ConvexHull{}, cube).depth));
}

}  // namespace
}  // namespace hapticd::geometry
