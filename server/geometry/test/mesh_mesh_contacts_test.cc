#include "server/geometry/mesh_mesh_contacts.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/geometry/triangle_triangle.h"

namespace hapticd::geometry {
namespace {

std::shared_ptr<const TriangleMesh> Share(TriangleMesh mesh) {
  return std::make_shared<const TriangleMesh>(std::move(mesh));
}

// All pairs, no BVH: B's triangle moved into A's frame exactly as the query does.
// (Pairs whose boxes are apart cannot meet; skipping them only saves time.)
std::vector<MeshMeshContact> BruteContacts(const TriangleMesh& a, const TriangleMesh& b,
                                           const Eigen::Isometry3d& X_AB) {
  std::vector<MeshMeshContact> contacts;
  for (int j : b.nondegenerate_triangles()) {
    const Triangle tb0 = b.triangle(j);
    const Triangle tb{X_AB * tb0.v0, X_AB * tb0.v1, X_AB * tb0.v2};
    const Aabb tb_box = Aabb::OfTriangle(tb);
    for (int i : a.nondegenerate_triangles()) {
      if (!AabbsOverlap(Aabb::OfTriangle(a.triangle(i)), tb_box)) continue;
      const TriangleIntersection x = IntersectTriangles(a.triangle(i), tb);
      if (x.intersect) contacts.push_back({i, j, x.coplanar, x.p0, x.p1});
    }
  }
  return contacts;
}

void SortByPair(std::vector<MeshMeshContact>& contacts) {
  std::sort(contacts.begin(), contacts.end(), [](const auto& x, const auto& y) {
    return std::tie(x.triangle_a, x.triangle_b) < std::tie(y.triangle_a, y.triangle_b);
  });
}

void ExpectSameContacts(const MeshBvh& a, const MeshBvh& b, const Eigen::Isometry3d& X_AB,
                        const std::string& what) {
  std::vector<MeshMeshContact> buffer(100000);
  const MeshMeshContacts result = FindMeshMeshContacts(a, b, X_AB, buffer);
  std::vector<MeshMeshContact> got(buffer.begin(), buffer.begin() + result.count);
  std::vector<MeshMeshContact> want = BruteContacts(a.mesh(), b.mesh(), X_AB);
  ASSERT_FALSE(result.truncated) << what;
  ASSERT_EQ(result.num_pairs, result.count) << what;
  ASSERT_EQ(got.size(), want.size()) << what;
  EXPECT_EQ(MeshesIntersect(a, b, X_AB), !want.empty()) << what;
  SortByPair(got);
  SortByPair(want);
  for (size_t k = 0; k < want.size(); ++k) {
    ASSERT_EQ(got[k].triangle_a, want[k].triangle_a) << what;
    ASSERT_EQ(got[k].triangle_b, want[k].triangle_b) << what;
    EXPECT_EQ(got[k].coplanar, want[k].coplanar) << what;
    EXPECT_EQ(got[k].p0, want[k].p0) << what;
    EXPECT_EQ(got[k].p1, want[k].p1) << what;
  }
}

Eigen::Isometry3d RandomPose(std::mt19937_64& rng, double reach) {
  std::normal_distribution<double> normal;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng))
                   .normalized()
                   .toRotationMatrix();
  X.translation() = reach * Vector3(normal(rng), normal(rng), normal(rng));
  return X;
}

TEST(MeshMeshContacts, MatchAllPairsBruteForceUnderRandomPoses) {
  const MeshBvh sphere(Share(MakeIcosphere(6, 1.0)));       // 720 triangles
  const MeshBvh torus(Share(MakeTorus(0.8, 0.25, 24, 12)));  // 576 triangles
  std::mt19937_64 rng(51);
  int touching = 0;
  for (int k = 0; k < 30; ++k) {
    const Eigen::Isometry3d X_AB = RandomPose(rng, 0.6);
    ExpectSameContacts(sphere, torus, X_AB, "sphere-torus pose " + std::to_string(k));
    touching += MeshesIntersect(sphere, torus, X_AB);
  }
  EXPECT_GT(touching, 20);
  // far apart: nothing
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() = Vector3(5, 0, 0);
  ExpectSameContacts(sphere, torus, far, "far");
  EXPECT_FALSE(MeshesIntersect(sphere, torus, far));
}

TEST(MeshMeshContacts, MeshAgainstItselfTouchesEveryNeighbour) {
  const MeshBvh sphere(Share(MakeIcosphere(4, 1.0)));
  ExpectSameContacts(sphere, sphere, Eigen::Isometry3d::Identity(), "self");
  std::vector<MeshMeshContact> buffer(10000);
  const MeshMeshContacts r =
      FindMeshMeshContacts(sphere, sphere, Eigen::Isometry3d::Identity(), buffer);
  // on a convex mesh a triangle meets exactly the triangles that share a corner with it
  // (itself included, coplanar)
  int sharing = 0;
  const auto& triangles = sphere.mesh().triangles();
  for (const auto& s : triangles) {
    for (const auto& t : triangles) {
      bool shares = false;
      for (int u : s) shares = shares || std::find(t.begin(), t.end(), u) != t.end();
      sharing += shares;
    }
  }
  EXPECT_EQ(sharing, 4100);  // 12 corners of valence 5, 150 of valence 6
  EXPECT_EQ(r.num_pairs, sharing);
}

TEST(MeshMeshContacts, BoxesTouchingFaceToFaceIntersectExactly) {
  // dyadic boxes, moved by dyadic translations: the transform is exact
  const MeshBvh box(Share(MakeBoxMesh({1, 1, 1}, 2)));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Vector3(2, 0.5, 0.25);  // B's face x = -1 lands on A's face x = 1
  EXPECT_TRUE(MeshesIntersect(box, box, X));
  ExpectSameContacts(box, box, X, "face to face");
  X.translation() = Vector3(2 + std::ldexp(1.0, -30), 0.5, 0.25);
  EXPECT_FALSE(MeshesIntersect(box, box, X));
  // corner on corner
  X.translation() = Vector3(2, 2, 2);
  EXPECT_TRUE(MeshesIntersect(box, box, X));
  ExpectSameContacts(box, box, X, "corner to corner");
}

TEST(MeshMeshContacts, FullBufferIsCountedAndFlagged) {
  const MeshBvh sphere(Share(MakeIcosphere(6, 1.0)));
  const MeshBvh torus(Share(MakeTorus(0.8, 0.25, 24, 12)));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Vector3(0.3, 0.1, 0.2);
  const size_t all = BruteContacts(sphere.mesh(), torus.mesh(), X).size();
  ASSERT_GT(all, 5u);
  MeshMeshContact small[5];
  const MeshMeshContacts r = FindMeshMeshContacts(sphere, torus, X, small);
  EXPECT_EQ(r.count, 5);
  EXPECT_EQ(r.num_pairs, static_cast<int>(all));
  EXPECT_TRUE(r.truncated);
}

TEST(MeshMeshContacts, NonFinitePoseFindsNothing) {
  const MeshBvh box(Share(MakeBoxMesh({1, 1, 1}, 1)));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Vector3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  MeshMeshContact buffer[8];
  EXPECT_EQ(FindMeshMeshContacts(box, box, X, buffer).num_pairs, 0);
  EXPECT_FALSE(MeshesIntersect(box, box, X));
  X.translation() = Vector3::Zero();
  X.linear()(1, 2) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(MeshesIntersect(box, box, X));
}

}  // namespace
}  // namespace hapticd::geometry
