#include "server/embree/embree_closest_point.h"

#include <gtest/gtest.h>

#include <limits>

#include "server/embree/test/embree_test_support.h"
#include "server/geometry/closest_point_triangle.h"

namespace hapticd::embree {
namespace {

using geometry::MeshClosestPoint;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The backend answer equals the native one: found, distance exactly; the same triangle
// (then the same point, feature and barycentrics) or another one exactly as close.
::testing::AssertionResult SameClosest(const TriangleMesh& mesh, const Vector3& p,
                                       const MeshClosestPoint& native,
                                       const MeshClosestPoint& backend) {
  if (native.found != backend.found || native.distance != backend.distance) {
    return ::testing::AssertionFailure() << "found " << native.found << "/" << backend.found
                                         << " distance " << native.distance << "/"
                                         << backend.distance;
  }
  if (!native.found) return ::testing::AssertionSuccess();
  if (native.triangle == backend.triangle) {
    if (native.point == backend.point && native.feature == backend.feature &&
        native.u == backend.u && native.v == backend.v) {
      return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << "same triangle, different point";
  }
  const double d2 = geometry::FindClosestPointOnTriangle(p, mesh.triangle(backend.triangle)).distance_squared;
  if (std::sqrt(d2) == native.distance) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "triangle " << backend.triangle << " is not a tie";
}

class EmbreeClosestPointTest : public ::testing::Test {
 protected:
  std::shared_ptr<const EmbreeDevice> device_ = std::make_shared<const EmbreeDevice>();
};

// Points near the surface, inside, outside, exactly on vertices and edge midpoints, and
// far away (answered natively), with and without a search radius.
TEST_F(EmbreeClosestPointTest, RandomPointsEqualNative) {
  std::mt19937_64 rng(21);
  for (const NamedMesh& named : TestMeshes()) {
    SCOPED_TRACE(named.name);
    const TriangleMesh& m = *named.mesh;
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    std::vector<Vector3> points;
    for (const auto& [p, q] : RandomSegments(m, 1500, rng)) points.push_back(p);
    for (int v = 0; v < m.num_vertices(); v += 7) points.push_back(m.vertices()[v]);
    for (int t = 0; t < m.num_triangles(); t += 11) {
      const geometry::Triangle tri = m.triangle(t);
      points.push_back(0.5 * (tri.v0 + tri.v1));
    }
    points.push_back(m.bounds().center() + Vector3(1e5, -2e5, 3e5));
    const double radius = 0.05 * m.size();
    int found_within = 0;
    for (const Vector3& p : points) {
      ASSERT_TRUE(SameClosest(m, p, geometry::FindClosestPointOnMesh(*bvh, p),
                              FindClosestPointOnMesh(mesh, p)))
          << "p " << p.transpose();
      const MeshClosestPoint native = geometry::FindClosestPointOnMesh(*bvh, p, radius);
      ASSERT_TRUE(SameClosest(m, p, native, FindClosestPointOnMesh(mesh, p, radius)))
          << "p " << p.transpose() << " within " << radius;
      found_within += native.found ? 1 : 0;
    }
    // the radius both found and excluded points
    EXPECT_GT(found_within, 100);
    EXPECT_LT(found_within, static_cast<int>(points.size()) - 100);
  }
}

// The search radius is closed, and bad input finds nothing.
TEST_F(EmbreeClosestPointTest, RadiusAndBadInput) {
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  auto bvh = std::make_shared<const geometry::MeshBvh>(box);
  const EmbreeMesh mesh(device_, bvh);
  const Vector3 p(0.1, 0.2, 1.0);  // 0.25 above the top face
  EXPECT_TRUE(FindClosestPointOnMesh(mesh, p, 0.25).found);
  EXPECT_EQ(FindClosestPointOnMesh(mesh, p, 0.25).distance, 0.25);
  EXPECT_FALSE(FindClosestPointOnMesh(mesh, p, std::nextafter(0.25, 0.0)).found);
  EXPECT_TRUE(FindClosestPointOnMesh(mesh, p, kInf).found);
  EXPECT_FALSE(FindClosestPointOnMesh(mesh, p, -1).found);
  EXPECT_FALSE(FindClosestPointOnMesh(mesh, p, kNan).found);
  EXPECT_FALSE(FindClosestPointOnMesh(mesh, Vector3(kNan, 0, 0)).found);
  EXPECT_FALSE(FindClosestPointOnMesh(mesh, Vector3(0, kInf, 0)).found);
  // a point on the surface, radius zero: as native (found when the rounded distance is 0)
  for (const Vector3& on : {Vector3(0.1, 0.2, 0.75), Vector3(0.125, 0.25, 0.75), Vector3(0.5, 1, 0.75)}) {
    SCOPED_TRACE(on.transpose());
    EXPECT_TRUE(SameClosest(*box, on, geometry::FindClosestPointOnMesh(*bvh, on, 0),
                            FindClosestPointOnMesh(mesh, on, 0)));
  }
  EXPECT_TRUE(FindClosestPointOnMesh(mesh, Vector3(0.125, 0.25, 0.75), 0).found);
}

}  // namespace
}  // namespace hapticd::embree
