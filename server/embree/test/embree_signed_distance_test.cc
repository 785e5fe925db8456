#include "server/embree/embree_signed_distance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "server/embree/test/embree_test_support.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/net/test/count_allocations.h"

namespace hapticd::embree {
namespace {

using geometry::MeshSignedDistance;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The backend answer equals the native one: inside, signed distance and found exactly;
// the closest point on the same triangle (then the same point, feature and
// barycentrics) or on another one exactly as close (a tie).
::testing::AssertionResult SameSignedDistance(const TriangleMesh& mesh, const Vector3& p,
                                              const MeshSignedDistance& native,
                                              const MeshSignedDistance& backend) {
  if (native.inside != backend.inside || native.signed_distance != backend.signed_distance ||
      native.closest.found != backend.closest.found) {
    return ::testing::AssertionFailure()
           << "inside " << native.inside << "/" << backend.inside << " signed distance "
           << native.signed_distance << "/" << backend.signed_distance;
  }
  const geometry::MeshClosestPoint& a = native.closest;
  const geometry::MeshClosestPoint& b = backend.closest;
  if (!a.found) return ::testing::AssertionSuccess();
  if (a.triangle == b.triangle) {
    if (a.point == b.point && a.feature == b.feature && a.u == b.u && a.v == b.v &&
        a.distance == b.distance) {
      return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << "same triangle, different closest point";
  }
  const double d2 =
      geometry::FindClosestPointOnTriangle(p, mesh.triangle(b.triangle)).distance_squared;
  // on the surface, either holder of p will do
  if (std::sqrt(d2) == a.distance || (a.distance == 0 && b.distance == 0)) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "triangle " << b.triangle << " is not a tie";
}

// The mesh with every triangle's winding reversed: normals point inwards.
TriangleMesh Inverted(const TriangleMesh& mesh) {
  std::vector<TriangleMesh::TriangleIndices> triangles = mesh.triangles();
  for (auto& f : triangles) std::swap(f[1], f[2]);
  return TriangleMesh(mesh.vertices(), triangles);
}

class EmbreeSignedDistanceTest : public ::testing::Test {
 protected:
  std::shared_ptr<const EmbreeDevice> device_ = std::make_shared<const EmbreeDevice>();
};

// Random points near and far, vertices (on the surface exactly), edge midpoints (on or a
// rounding beside an edge) and a far point (answered natively), on every test mesh and
// the icosphere wound inwards: inside, signed distance and closest point equal native.
TEST_F(EmbreeSignedDistanceTest, RandomPointsEqualNative) {
  std::mt19937_64 rng(61);
  std::vector<NamedMesh> meshes = TestMeshes();
  meshes.push_back({"inward icosphere", Share(Inverted(geometry::MakeIcosphere(9, 1.0)))});
  for (const NamedMesh& named : meshes) {
    SCOPED_TRACE(named.name);
    const TriangleMesh& m = *named.mesh;
    auto bvh = std::make_shared<const geometry::MeshBvh>(named.mesh);
    const EmbreeMesh mesh(device_, bvh);
    std::vector<Vector3> points;
    for (const auto& [p, q] : RandomSegments(m, 3000, rng)) {
      points.push_back(p);
      points.push_back(q);
    }
    for (int v = 0; v < m.num_vertices(); v += 3) points.push_back(m.vertices()[v]);
    for (int t = 0; t < m.num_triangles(); t += 3) {
      const geometry::Triangle tri = m.triangle(t);
      points.push_back(0.5 * (tri.v0 + tri.v1));
      points.push_back((tri.v0 + tri.v1 + tri.v2) / 3);
    }
    points.push_back(m.bounds().center());
    points.push_back(m.bounds().center() + Vector3(1e5, -2e5, 3e5));
    int inside = 0;
    for (const Vector3& p : points) {
      const MeshSignedDistance native = geometry::CalcSignedDistanceToMesh(*bvh, p);
      ASSERT_TRUE(SameSignedDistance(m, p, native, CalcSignedDistanceToMesh(mesh, p)))
          << "p " << p.transpose();
      ASSERT_EQ(IsPointInsideMesh(mesh, p), native.inside) << "p " << p.transpose();
      inside += native.inside ? 1 : 0;
    }
    // both sides were exercised
    EXPECT_GT(inside, 500);
    EXPECT_LT(inside, static_cast<int>(points.size()) - 500);
  }
}

// Points exactly on the box's faces, edges and corners (dyadic, so exact) are inside at
// distance 0, the closest point being the point itself; just off the surface, the side
// is the normal's.
TEST_F(EmbreeSignedDistanceTest, OnTheSurfaceIsInside) {
  auto box = Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4));
  auto bvh = std::make_shared<const geometry::MeshBvh>(box);
  const EmbreeMesh mesh(device_, bvh);
  std::mt19937_64 rng(62);
  std::uniform_int_distribution<int> sixteenth(-8, 8);
  for (int k = 0; k < 3000; ++k) {
    Vector3 p(sixteenth(rng) / 16.0, 2 * sixteenth(rng) / 16.0, 1.5 * sixteenth(rng) / 16.0);
    const int axis = k % 3;
    const double side = (k / 3) % 2 == 0 ? 1 : -1;
    p[axis] = side * box->bounds().max[axis];
    const MeshSignedDistance on = CalcSignedDistanceToMesh(mesh, p);
    ASSERT_TRUE(SameSignedDistance(*box, p, geometry::CalcSignedDistanceToMesh(*bvh, p), on))
        << "p " << p.transpose();
    EXPECT_TRUE(on.inside);
    EXPECT_EQ(on.signed_distance, 0);
    EXPECT_EQ(on.closest.point, p);
    // 1e-12 out along the face normal: outside; in: inside
    Vector3 off = p;
    off[axis] += side * 1e-12;
    EXPECT_FALSE(IsPointInsideMesh(mesh, off)) << "p " << off.transpose();
    off[axis] -= side * 2e-12;
    EXPECT_TRUE(IsPointInsideMesh(mesh, off)) << "p " << off.transpose();
  }
}

// Many triangles exactly as close: the centre of an icosphere and of a box. The distance
// and side equal native whichever triangle each picks.
TEST_F(EmbreeSignedDistanceTest, EquidistantPointsEqualNative) {
  for (const auto& shape : {Share(geometry::MakeIcosphere(9, 1.0)),
                            Share(geometry::MakeBoxMesh({1, 1, 1}, 8))}) {
    auto bvh = std::make_shared<const geometry::MeshBvh>(shape);
    const EmbreeMesh mesh(device_, bvh);
    const Vector3 centre = Vector3::Zero();
    const MeshSignedDistance backend = CalcSignedDistanceToMesh(mesh, centre);
    EXPECT_TRUE(SameSignedDistance(*shape, centre, geometry::CalcSignedDistanceToMesh(*bvh, centre),
                                   backend));
    EXPECT_TRUE(backend.inside);
    EXPECT_LT(backend.signed_distance, 0);
  }
}

// NaN or infinite input: not found, outside, at once; a far point is answered natively.
TEST_F(EmbreeSignedDistanceTest, BadAndFarInput) {
  auto sphere = Share(geometry::MakeIcosphere(6, 1.0));
  auto bvh = std::make_shared<const geometry::MeshBvh>(sphere);
  const EmbreeMesh mesh(device_, bvh);
  for (const Vector3& bad : {Vector3(kNan, 0, 0), Vector3(0, kInf, 0), Vector3(0, 0, -kInf)}) {
    const MeshSignedDistance d = CalcSignedDistanceToMesh(mesh, bad);
    EXPECT_FALSE(d.closest.found);
    EXPECT_FALSE(d.inside);
    EXPECT_EQ(d.signed_distance, 0);
    EXPECT_FALSE(IsPointInsideMesh(mesh, bad));
  }
  const Vector3 far(1e6, 0.01, 0);
  ASSERT_FALSE(mesh.IsTrustedPoint(far));
  const MeshSignedDistance native = geometry::CalcSignedDistanceToMesh(*bvh, far);
  EXPECT_TRUE(SameSignedDistance(*sphere, far, native, CalcSignedDistanceToMesh(mesh, far)));
  EXPECT_GT(native.signed_distance, 0);

  // many NaN queries in a row neither crash nor hang
  std::mt19937_64 rng(63);
  std::uniform_real_distribution<double> unit(-2, 2);
  int inside = 0;
  for (int i = 0; i < 100000; ++i) {
    inside += IsPointInsideMesh(mesh, Vector3(unit(rng), kNan, unit(rng))) ? 1 : 0;
  }
  EXPECT_EQ(inside, 0);
}

// The queries allocate nothing, near the surface or far from it (operator new is counted
// by count_allocations.h; Embree's own heap is not).
TEST_F(EmbreeSignedDistanceTest, QueriesDoNotAllocate) {
  auto torus = Share(geometry::MakeTorus(1.0, 0.35, 36, 18));
  auto bvh = std::make_shared<const geometry::MeshBvh>(torus);
  const EmbreeMesh mesh(device_, bvh);
  std::mt19937_64 rng(64);
  const auto segments = RandomSegments(*torus, 200, rng);
  const long before = hapticd::testing::AllocationCount();
  int inside = 0;
  for (const auto& [p, q] : segments) {
    inside += IsPointInsideMesh(mesh, p) ? 1 : 0;
    inside += CalcSignedDistanceToMesh(mesh, q).inside ? 1 : 0;
  }
  EXPECT_EQ(hapticd::testing::AllocationCount(), before);
  EXPECT_GT(inside, 0);
}

}  // namespace
}  // namespace hapticd::embree
