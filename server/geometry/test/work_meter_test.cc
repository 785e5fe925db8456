#include "server/geometry/work_meter.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"
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
