#include "server/geometry/work_meter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "server/geometry/convex_hull.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/point_hull.h"
#include "server/geometry/sphere_sweep.h"

namespace hapticd::geometry {
namespace {

// n different triangles in the plane z = 0 with one and the same bounding box (a fan
// whose apex slides along the box's top edge): no BVH can split them, so a query near
// the plane has to visit every one. The pathological input the meter exists for.
std::shared_ptr<const MeshBvh> MakeUnsplittableStack(int n) {
  std::vector<Vector3> vertices = {{-1, -1, 0}, {1, -1, 0}};
  std::vector<TriangleMesh::TriangleIndices> triangles;
  for (int i = 0; i < n; ++i) {
    vertices.push_back({-1 + 2.0 * i / (n - 1), 1, 0});
    triangles.push_back({0, 1, i + 2});
  }
  return std::make_shared<MeshBvh>(std::make_shared<TriangleMesh>(vertices, triangles));
}

// Each query a tick makes on a mesh, from just above the stack's plane.
struct Query {
  const char* name;
  bool (*run)(const MeshBvh& bvh);  // whether it found something
};
const Query kQueries[] = {
    {"closest point", [](const MeshBvh& bvh) { return FindClosestPointOnMesh(bvh, {0.1, 0.2, 0.01}, 1).found; }},
    {"segment", [](const MeshBvh& bvh) { return FindFirstSegmentHit(bvh, {0.1, 0.2, 0.01}, {0.1, 0.2, -0.01}).hit; }},
    {"point sweep", [](const MeshBvh& bvh) { return SweepSphereMesh(bvh, {0.1, 0.2, 0.01}, {0.1, 0.2, -0.01}, 0).hit; }},
    {"sphere sweep",
     [](const MeshBvh& bvh) { return SweepSphereMesh(bvh, {0.1, 0.2, 0.02}, {0.1, 0.2, -0.01}, 0.005).hit; }},
};

// Unmetered, each query visits the whole stack; under a budget it stops once the budget
// is spent, having charged at most one leaf more than it.
TEST(WorkMeter, StopsEveryMeshQueryOnAnUnsplittableStack) {
  constexpr int kTriangles = 20000;
  constexpr int64_t kBudget = 1000;
  const auto stack = MakeUnsplittableStack(kTriangles);
  for (const Query& query : kQueries) {
    int64_t whole = 0;
    {
      const WorkMeter unbounded(int64_t{1} << 40);
      EXPECT_TRUE(query.run(*stack)) << query.name;
      whole = unbounded.used();
    }
    EXPECT_GT(whole, kTriangles) << query.name << ": every triangle tested";
    const WorkMeter meter(kBudget);
    query.run(*stack);
    EXPECT_TRUE(meter.exhausted()) << query.name;
    EXPECT_LE(meter.used(), kBudget + BvhBuildOptions{}.max_leaf_size) << query.name;
  }
}

// On an ordinary mesh the same budget is far from spent, and the answers are the
// unmetered ones.
TEST(WorkMeter, LeavesOrdinaryQueriesAlone) {
  const MeshBvh sphere(std::make_shared<TriangleMesh>(MakeIcosphere(71, 0.05)));
  const Vector3 above(0.01, 0.02, 0.06);
  const Vector3 below(0.01, 0.02, 0.0);
  const MeshClosestPoint free_closest = FindClosestPointOnMesh(sphere, above);
  const SphereSweepHit free_sweep = SweepSphereMesh(sphere, above, below, 0.005);
  const WorkMeter meter(1000);
  const MeshClosestPoint closest = FindClosestPointOnMesh(sphere, above);
  const SphereSweepHit sweep = SweepSphereMesh(sphere, above, below, 0.005);
  EXPECT_FALSE(meter.exhausted()) << meter.used();
  EXPECT_GT(meter.used(), 0);
  EXPECT_EQ(closest.triangle, free_closest.triangle);
  EXPECT_EQ(closest.point, free_closest.point);
  EXPECT_EQ(sweep.t, free_sweep.t);
  EXPECT_EQ(sweep.triangle, free_sweep.triangle);
}

// A hull of many faces (a finely tessellated sphere's: 18,000 faces) costs a point
// inside a unit per eight faces and one outside GJK's searches over its vertices; under a
// budget, inside finds nothing once the faces cannot be paid for, and outside GJK stops
// early. A small hull's queries stay within the budget and answer as unmetered.
TEST(WorkMeter, StopsThePointHullQueryOnAHullOfManyFaces) {
  constexpr int64_t kBudget = 1000;
  const ConvexHull hull = BuildConvexHull(MakeIcosphere(30, 0.05).vertices());
  ASSERT_EQ(hull.faces.size(), 18000u);
  const Vector3 inside(0.001, 0.002, 0.01);
  {
    const WorkMeter unbounded(int64_t{1} << 40);
    EXPECT_TRUE(CalcPointHullDistance(hull, inside).found);
    EXPECT_GE(unbounded.used(), 18000 / 8);
  }
  {
    const WorkMeter meter(kBudget);
    EXPECT_FALSE(CalcPointHullDistance(hull, inside).found);
    EXPECT_TRUE(meter.exhausted());
  }
  // outside, from the far side of where GJK starts its searches (+x)
  const Vector3 outside(-0.0501, 0.0003, 0.0002);
  int64_t whole = 0;
  {
    const WorkMeter unbounded(int64_t{1} << 40);
    EXPECT_TRUE(CalcPointHullDistance(hull, outside).found);
    whole = unbounded.used();
  }
  EXPECT_GT(whole, 100) << "a hill climb across the hull";
  const WorkMeter meter(whole / 4);
  const PointHullResult partial = CalcPointHullDistance(hull, outside);
  EXPECT_TRUE(meter.exhausted());
  EXPECT_LT(meter.used(), whole) << "GJK stopped early";
  EXPECT_FALSE(std::isnan(partial.signed_distance));
}

TEST(WorkMeter, LeavesSmallHullsAlone) {
  const ConvexHull hull = BuildConvexHull(MakeIcosphere(3, 0.05).vertices());
  for (const Vector3& p : {Vector3(0.001, 0.002, 0.01), Vector3(-0.06, 0.01, 0.02)}) {
    const PointHullResult free = CalcPointHullDistance(hull, p);
    const WorkMeter meter(100);
    const PointHullResult metered = CalcPointHullDistance(hull, p);
    EXPECT_FALSE(meter.exhausted()) << meter.used();
    EXPECT_GT(meter.used(), 0);
    EXPECT_EQ(metered.found, free.found);
    EXPECT_EQ(metered.signed_distance, free.signed_distance);
    EXPECT_EQ(metered.point, free.point);
  }
}

// A meter inside another charges the outer one with what it used; with none running a
// thread is unmetered.
TEST(WorkMeter, NestedMetersChargeTheOuterOne) {
  EXPECT_TRUE(WorkMeter::Charge(1'000'000'000));
  const WorkMeter outer(100);
  EXPECT_TRUE(WorkMeter::Charge(60));
  {
    const WorkMeter inner(10);
    EXPECT_FALSE(WorkMeter::Charge(30));
    EXPECT_TRUE(inner.exhausted());
    EXPECT_EQ(inner.used(), 30);
  }
  EXPECT_EQ(outer.used(), 90);
  EXPECT_FALSE(outer.exhausted());
  EXPECT_FALSE(WorkMeter::Charge(11));
  EXPECT_TRUE(outer.exhausted());
}

}  // namespace
}  // namespace hapticd::geometry
