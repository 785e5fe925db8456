#include "server/embree/embree_mesh_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <tuple>
#include <vector>

#include "server/embree/test/embree_test_support.h"

namespace hapticd::embree {
namespace {

using geometry::MeshMeshContact;
using geometry::MeshMeshContacts;

// Sorted by triangle pair, for comparing as sets.
std::vector<MeshMeshContact> Sorted(std::vector<MeshMeshContact> contacts, int count) {
  contacts.resize(count);
  std::sort(contacts.begin(), contacts.end(), [](const MeshMeshContact& x, const MeshMeshContact& y) {
    return std::tie(x.triangle_a, x.triangle_b) < std::tie(y.triangle_a, y.triangle_b);
  });
  return contacts;
}

class EmbreeMeshMeshTest : public ::testing::Test {
 protected:
  // Both meshes in one frame, compared with the native walk under the identity: the same
  // pairs, flags and segments.
  void ExpectSameContacts(const std::shared_ptr<const TriangleMesh>& a,
                          const std::shared_ptr<const TriangleMesh>& b, int min_pairs) {
    auto bvh_a = std::make_shared<const geometry::MeshBvh>(a);
    auto bvh_b = std::make_shared<const geometry::MeshBvh>(b);
    const EmbreeMesh mesh_a(device_, bvh_a), mesh_b(device_, bvh_b);
    std::vector<MeshMeshContact> native(20000), backend(20000);
    const MeshMeshContacts n =
        geometry::FindMeshMeshContacts(*bvh_a, *bvh_b, Eigen::Isometry3d::Identity(), native);
    const MeshMeshContacts e = FindMeshMeshContacts(mesh_a, mesh_b, backend);
    ASSERT_FALSE(n.truncated);
    EXPECT_GE(n.num_pairs, min_pairs);
    EXPECT_EQ(e.num_pairs, n.num_pairs);
    EXPECT_EQ(e.count, n.count);
    EXPECT_FALSE(e.truncated);
    const auto sorted_n = Sorted(native, n.count), sorted_e = Sorted(backend, e.count);
    for (size_t i = 0; i < std::min(sorted_n.size(), sorted_e.size()); ++i) {
      ASSERT_EQ(sorted_e[i].triangle_a, sorted_n[i].triangle_a) << i;
      ASSERT_EQ(sorted_e[i].triangle_b, sorted_n[i].triangle_b) << i;
      EXPECT_EQ(sorted_e[i].coplanar, sorted_n[i].coplanar) << i;
      EXPECT_EQ(sorted_e[i].p0, sorted_n[i].p0) << i;
      EXPECT_EQ(sorted_e[i].p1, sorted_n[i].p1) << i;
    }
    EXPECT_EQ(MeshesIntersect(mesh_a, mesh_b), n.num_pairs > 0);
  }

  std::shared_ptr<const EmbreeDevice> device_ = std::make_shared<const EmbreeDevice>();
};

TEST_F(EmbreeMeshMeshTest, OverlappingMeshesEqualNative) {
  std::mt19937_64 rng(31);
  auto sphere = Share(geometry::MakeIcosphere(9, 1.0));
  for (int k = 0; k < 4; ++k) {
    SCOPED_TRACE(k);
    const Vector3 offset = geometry::RandomBall(rng, 1, 1.2)[0];
    auto torus = Share(Moved(geometry::MakeTorus(0.8, 0.3, 36, 18), geometry::RandomRotation(rng), offset));
    ExpectSameContacts(sphere, torus, 1);
  }
}

// Boxes on a dyadic grid sharing a face plane exactly: every touching pair is coplanar
// or meets along an edge, decided exactly by both.
TEST_F(EmbreeMeshMeshTest, TouchingBoxesEqualNative) {
  auto a = Share(geometry::MakeBoxMesh({0.5, 0.5, 0.5}, 4));
  auto b = Share(Moved(geometry::MakeBoxMesh({0.5, 0.25, 0.25}, 4), geometry::Matrix3::Identity(),
                       Vector3(1, 0.125, 0)));
  ExpectSameContacts(a, b, 16);
}

TEST_F(EmbreeMeshMeshTest, SeparatedMeshesHaveNoContacts) {
  auto a = Share(geometry::MakeIcosphere(6, 1.0));
  auto b = Share(Moved(geometry::MakeIcosphere(6, 1.0), geometry::Matrix3::Identity(), Vector3(2.01, 0, 0)));
  const EmbreeMesh mesh_a(device_, std::make_shared<const geometry::MeshBvh>(a));
  const EmbreeMesh mesh_b(device_, std::make_shared<const geometry::MeshBvh>(b));
  std::vector<MeshMeshContact> out(10);
  const MeshMeshContacts contacts = FindMeshMeshContacts(mesh_a, mesh_b, out);
  EXPECT_EQ(contacts.num_pairs, 0);
  EXPECT_EQ(contacts.count, 0);
  EXPECT_FALSE(MeshesIntersect(mesh_a, mesh_b));
}

// A short buffer keeps some pairs and counts all; other devices and one mesh twice are
// answered natively.
TEST_F(EmbreeMeshMeshTest, TruncationAndNativeFallbacks) {
  auto a = Share(geometry::MakeIcosphere(9, 1.0));
  auto b = Share(Moved(geometry::MakeIcosphere(9, 1.0), geometry::Matrix3::Identity(), Vector3(1.0, 0.3, 0)));
  auto bvh_a = std::make_shared<const geometry::MeshBvh>(a);
  auto bvh_b = std::make_shared<const geometry::MeshBvh>(b);
  const EmbreeMesh mesh_a(device_, bvh_a), mesh_b(device_, bvh_b);
  std::vector<MeshMeshContact> all(20000);
  const int num_pairs =
      geometry::FindMeshMeshContacts(*bvh_a, *bvh_b, Eigen::Isometry3d::Identity(), all).num_pairs;
  ASSERT_GT(num_pairs, 3);

  std::vector<MeshMeshContact> out(3);
  const MeshMeshContacts few = FindMeshMeshContacts(mesh_a, mesh_b, out);
  EXPECT_EQ(few.count, 3);
  EXPECT_EQ(few.num_pairs, num_pairs);
  EXPECT_TRUE(few.truncated);
  // each kept pair is one of the native pairs
  for (const MeshMeshContact& c : out) {
    EXPECT_TRUE(std::any_of(all.begin(), all.begin() + num_pairs, [&](const MeshMeshContact& x) {
      return x.triangle_a == c.triangle_a && x.triangle_b == c.triangle_b;
    }));
  }

  const EmbreeMesh other_device(std::make_shared<const EmbreeDevice>(), bvh_b);
  EXPECT_EQ(FindMeshMeshContacts(mesh_a, other_device, all).num_pairs, num_pairs);
  EXPECT_TRUE(MeshesIntersect(mesh_a, other_device));
  const int self_pairs =
      geometry::FindMeshMeshContacts(*bvh_a, *bvh_a, Eigen::Isometry3d::Identity(), all).num_pairs;
  EXPECT_EQ(FindMeshMeshContacts(mesh_a, mesh_a, all).num_pairs, self_pairs);
}

}  // namespace
}  // namespace hapticd::embree
