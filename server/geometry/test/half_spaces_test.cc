#include "server/geometry/half_spaces.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

namespace hapticd::geometry {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

HalfSpace Through(const Vector3& normal, const Vector3& point) {
  const Vector3 n = normal.normalized();
  return {n, n.dot(point)};
}

TEST(NearestPointInHalfSpaces, AGoalInsideIsTheAnswer) {
  const std::vector<HalfSpace> floor_and_wall{{Vector3::UnitZ(), 0}, {Vector3::UnitX(), -1}};
  EXPECT_EQ(NearestPointInHalfSpaces({0.5, 2, 3}, floor_and_wall), Vector3(0.5, 2, 3));
  EXPECT_EQ(NearestPointInHalfSpaces({0.5, 2, 3}, {}), Vector3(0.5, 2, 3));
  // on the boundary, and a rounding's width outside it
  EXPECT_EQ(NearestPointInHalfSpaces({0.5, 2, 0}, floor_and_wall), Vector3(0.5, 2, 0));
  EXPECT_EQ(NearestPointInHalfSpaces({0.5, 2, -1e-13}, floor_and_wall), Vector3(0.5, 2, -1e-13));
}

TEST(NearestPointInHalfSpaces, OneFaceOneEdgeOneCorner) {
  const HalfSpace floor{Vector3::UnitZ(), 0}, wall{Vector3::UnitX(), 0}, back{Vector3::UnitY(), 0};
  const std::vector<HalfSpace> face{floor}, edge{floor, wall}, corner{floor, wall, back};
  EXPECT_TRUE(NearestPointInHalfSpaces({1, 2, -3}, face).isApprox(Vector3(1, 2, 0)));
  EXPECT_TRUE(NearestPointInHalfSpaces({-1, 2, -3}, edge).isApprox(Vector3(0, 2, 0)));
  // below the floor but in front of the wall: only the floor is active
  EXPECT_TRUE(NearestPointInHalfSpaces({1, 2, -3}, edge).isApprox(Vector3(1, 2, 0)));
  EXPECT_TRUE(NearestPointInHalfSpaces({-1, -2, -3}, corner).isZero(1e-15));
  // a wedge of 90 degrees about the x axis, the goal below its edge
  const std::vector<HalfSpace> wedge{Through({0, 1, 1}, Vector3::Zero()), Through({0, -1, 1}, Vector3::Zero())};
  EXPECT_TRUE(NearestPointInHalfSpaces({0.3, 0, -2}, wedge).isApprox(Vector3(0.3, 0, 0)));
  EXPECT_TRUE(NearestPointInHalfSpaces({0.3, 3, -1}, wedge).isApprox(Vector3(0.3, 1, 1)));
}

TEST(NearestPointInHalfSpaces, DependentPlanesAreSkippedNotFatal) {
  // the same floor twice, and a floor below it: the higher one decides
  const std::vector<HalfSpace> floors{{Vector3::UnitZ(), 0}, {Vector3::UnitZ(), 0}, {Vector3::UnitZ(), -1}};
  EXPECT_TRUE(NearestPointInHalfSpaces({1, 1, -5}, floors).isApprox(Vector3(1, 1, 0)));
  // four planes through one corner (a pyramid's apex): three of them suffice
  const std::vector<HalfSpace> apex{Through({1, 0, 1}, Vector3::Zero()), Through({-1, 0, 1}, Vector3::Zero()),
                                    Through({0, 1, 1}, Vector3::Zero()), Through({0, -1, 1}, Vector3::Zero())};
  EXPECT_TRUE(NearestPointInHalfSpaces({0, 0, -1}, apex).isZero(1e-15));
}

TEST(NearestPointInHalfSpaces, DegenerateAnswersAreTheGoal) {
  // nothing between the planes: z >= 1 and z <= 0
  const std::vector<HalfSpace> empty{{Vector3::UnitZ(), 1}, {-Vector3::UnitZ(), 0}};
  EXPECT_EQ(NearestPointInHalfSpaces({1, 2, 0.5}, empty), Vector3(1, 2, 0.5));
  // more than kMaxHalfSpaces
  const std::vector<HalfSpace> many(kMaxHalfSpaces + 1, HalfSpace{Vector3::UnitZ(), 0});
  EXPECT_EQ(NearestPointInHalfSpaces({1, 2, -1}, many), Vector3(1, 2, -1));
  // non-finite goal, non-finite plane
  const Vector3 nan_goal = NearestPointInHalfSpaces({kNan, 0, -1}, std::vector<HalfSpace>{{Vector3::UnitZ(), 0}});
  EXPECT_TRUE(std::isnan(nan_goal.x()));
  EXPECT_EQ(nan_goal.z(), -1);
  const std::vector<HalfSpace> nan_plane{{Vector3::UnitZ(), 0}, {Vector3(kNan, 0, 1), 0}};
  EXPECT_EQ(NearestPointInHalfSpaces({1, 2, -1}, nan_plane), Vector3(1, 2, -1));
}

// Dykstra's alternating projections: the nearest point of an intersection of convex
// sets, by a method that shares nothing with the active-set search.
Vector3 DykstraProjection(const Vector3& goal, const std::vector<HalfSpace>& half_spaces) {
  Vector3 x = goal;
  std::vector<Vector3> corrections(half_spaces.size(), Vector3::Zero());
  // until a whole sweep leaves the point and every correction where they were (the
  // point alone can stall for a sweep while the corrections still move)
  for (int sweep = 0; sweep < 1000000; ++sweep) {
    double change = 0;
    for (std::size_t i = 0; i < half_spaces.size(); ++i) {
      const Vector3 y = x + corrections[i];
      const double violation = half_spaces[i].offset - half_spaces[i].normal.dot(y);
      const Vector3 projected = violation > 0 ? Vector3(y + violation * half_spaces[i].normal) : y;
      change = std::max({change, (projected - x).norm(), (y - projected - corrections[i]).norm()});
      corrections[i] = y - projected;
      x = projected;
    }
    if (change < 1e-14) break;
  }
  return x;
}

// Random polyhedra whose half-spaces all hold a common point (so the intersection is
// never empty), normals within spread (radians, about) of +z; answers against Dykstra.
// Returns how many goals were outside.
int CheckRandomPolyhedra(std::mt19937_64& rng, int trials, double spread) {
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> slack(0, 0.5);
  std::uniform_int_distribution<int> count(1, kMaxHalfSpaces);
  int projected = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const Vector3 inside(gauss(rng), gauss(rng), gauss(rng));
    std::vector<HalfSpace> half_spaces;
    for (int i = count(rng); i > 0; --i) {
      const Vector3 normal = (Vector3::UnitZ() + spread * Vector3(gauss(rng), gauss(rng), gauss(rng))).normalized();
      half_spaces.push_back({normal, normal.dot(inside) - slack(rng)});
    }
    const Vector3 goal = inside + 2 * Vector3(gauss(rng), gauss(rng), gauss(rng));
    const Vector3 answer = NearestPointInHalfSpaces(goal, half_spaces);
    const Vector3 oracle = DykstraProjection(goal, half_spaces);
    EXPECT_TRUE(SatisfiesHalfSpaces(answer, half_spaces)) << "spread " << spread << ", trial " << trial;
    EXPECT_LT((answer - oracle).norm(), 1e-7) << "spread " << spread << ", trial " << trial << ": "
                                              << answer.transpose() << " against " << oracle.transpose();
    projected += answer != goal;
  }
  return projected;
}

TEST(NearestPointInHalfSpaces, RandomPolyhedraAgainstDykstra) {
  std::mt19937_64 rng(1205);
  EXPECT_GT(CheckRandomPolyhedra(rng, 2000, 1e6), 1000);  // any directions; most goals start outside
}

TEST(NearestPointInHalfSpaces, NearlyParallelFacetsAgainstDykstra) {
  // the planes a proxy meets on a fine mesh: neighbouring facets a few degrees apart
  std::mt19937_64 rng(1206);
  EXPECT_GT(CheckRandomPolyhedra(rng, 300, 0.05), 100);
}

}  // namespace
}  // namespace hapticd::geometry
