// The batch point queries: a ClosestPointBatch answers as ClosestPoint asked of each
// point, a FindContactsBatch as FindContacts asked of each centre (meshes on both
// backends, primitives and a plane alike), a fan of rays from one origin as the same
// rays each with its origin, and each bound and bad value is refused by name.
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/mesh_generators.h"
#include "server/net/point_batches.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;
using testing::Harness;

void ExpectError(const v1::Reply& reply, v1::Error::Code code, const std::string& message) {
  ASSERT_TRUE(reply.has_error()) << reply.DebugString();
  EXPECT_EQ(reply.error().code(), code) << reply.error().message();
  EXPECT_EQ(reply.error().message(), message);
}

void SetVec3(const Vector3& v, v1::Vec3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

Vector3 At(const google::protobuf::RepeatedField<double>& values, int i) {
  return {values[3 * i], values[3 * i + 1], values[3 * i + 2]};
}

// The harness's box and floor, two icosphere meshes (one per backend) and a sphere.
void AddMeshesAndSphere(Harness& harness) {
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(4, 0.05);
  for (const auto& [name, x, backend] : {std::tuple{"on_embree", 0.2, v1::RAY_BACKEND_EMBREE},
                                        std::tuple{"on_native", -0.2, v1::RAY_BACKEND_NATIVE}}) {
    v1::Request add;
    *add.mutable_add_object()->mutable_object() =
        testing::MeshObject(name, ball, x, v1::REPRESENTATION_MESH, backend);
    ASSERT_TRUE(harness.Call(add).has_done());
  }
  v1::Request add;
  v1::Object* sphere = add.mutable_add_object()->mutable_object();
  sphere->set_name("ball");
  sphere->mutable_material()->set_stiffness(1000);
  sphere->mutable_shape()->mutable_sphere()->set_radius(0.04);
  sphere->mutable_pose()->mutable_position()->set_y(0.15);
  ASSERT_TRUE(harness.Call(add).has_done());
}

// Random points about the objects, some inside them, some far from everything.
std::vector<Vector3> RandomPoints(int n, uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> place(-0.3, 0.3);
  std::vector<Vector3> points(n);
  for (Vector3& p : points) p = {place(random), place(random), place(random) - 0.05};
  return points;
}

// The name the batch's table gives an object index.
std::string NameOf(const v1::ObjectNames& names, int index) {
  for (int k = 0; k < names.indices_size(); ++k) {
    if (static_cast<int>(names.indices(k)) == index) return names.names(k);
  }
  return "<unnamed " + std::to_string(index) + ">";
}

TEST(PointBatches, ClosestPointsAnswerAsSinglePoints) {
  Harness harness;
  AddMeshesAndSphere(harness);
  const std::vector<Vector3> points = RandomPoints(600, 5);
  v1::Request batch;
  v1::ClosestPointBatch* query = batch.mutable_closest_point_batch();
  query->set_max_distance(0.12);
  for (const Vector3& p : points) {
    for (int k = 0; k < 3; ++k) query->add_points(p[k]);
  }
  const v1::Reply reply = harness.Call(batch);
  ASSERT_TRUE(reply.has_closest_points()) << reply.error().message();
  const v1::ClosestPoints& nearest = reply.closest_points();
  EXPECT_EQ(nearest.scene_version(), harness.publisher.current()->version());
  ASSERT_EQ(nearest.found_size(), 600);
  ASSERT_EQ(nearest.points_size(), 1800);
  // the names table lists exactly the indices that occur, ascending
  for (int k = 1; k < nearest.object_names().indices_size(); ++k) {
    EXPECT_LT(nearest.object_names().indices(k - 1), nearest.object_names().indices(k));
  }

  std::map<std::string, int> by_object;
  int missed = 0;
  for (int i = 0; i < 600; ++i) {
    v1::Request single;
    SetVec3(points[i], single.mutable_closest_point()->mutable_point());
    single.mutable_closest_point()->set_max_distance(0.12);
    const v1::ClosestPointResult one = harness.Call(single).closest_point();
    ASSERT_EQ(nearest.found(i), one.found()) << i;
    if (!one.found()) {
      ++missed;
      EXPECT_EQ(nearest.objects(i), -1);
      EXPECT_EQ(nearest.signed_distance(i), std::numeric_limits<double>::infinity());
      EXPECT_EQ(At(nearest.points(), i), Vector3::Zero());
      continue;
    }
    const std::string name = NameOf(nearest.object_names(), nearest.objects(i));
    EXPECT_EQ(name, one.object()) << i;
    EXPECT_EQ(harness.publisher.current()->object(nearest.objects(i)).name, one.object()) << i;
    ++by_object[name];
    EXPECT_EQ(nearest.signed_distance(i), one.signed_distance()) << i;
    EXPECT_EQ(At(nearest.points(), i), Vector3(one.point().x(), one.point().y(), one.point().z())) << i;
    EXPECT_EQ(At(nearest.normals(), i), Vector3(one.normal().x(), one.normal().y(), one.normal().z())) << i;
  }
  EXPECT_GT(missed, 10);
  for (const char* name : {"on_embree", "on_native", "ball", "box"}) EXPECT_GT(by_object[name], 5) << name;
}

TEST(PointBatches, ContactsAnswerAsSingleSpheresLaidEndToEnd) {
  Harness harness;
  AddMeshesAndSphere(harness);
  const std::vector<Vector3> centers = RandomPoints(400, 6);
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> size(0, 0.3);
  v1::Request batch;
  v1::FindContactsBatch* query = batch.mutable_find_contacts_batch();
  std::vector<double> radii;
  for (const Vector3& c : centers) {
    for (int k = 0; k < 3; ++k) query->add_centers(c[k]);
    radii.push_back(radii.size() % 7 == 0 ? 0.0 : size(random));
    query->add_radii(radii.back());
  }
  const v1::Reply reply = harness.Call(batch);
  ASSERT_TRUE(reply.has_contacts_batch()) << reply.error().message();
  const v1::ContactsBatch& found = reply.contacts_batch();
  ASSERT_EQ(found.counts_size(), 400);

  int k = 0;
  int several = 0;
  for (int i = 0; i < 400; ++i) {
    v1::Request single;
    SetVec3(centers[i], single.mutable_find_contacts()->mutable_center());
    single.mutable_find_contacts()->set_radius(radii[i]);
    const v1::ContactsResult one = harness.Call(single).contacts();
    ASSERT_EQ(static_cast<int>(found.counts(i)), one.contacts_size()) << i;
    several += one.contacts_size() > 1;
    for (const v1::Contact& contact : one.contacts()) {
      EXPECT_EQ(NameOf(found.object_names(), found.objects(k)), contact.object()) << i;
      EXPECT_EQ(found.depths(k), contact.depth()) << i;
      EXPECT_EQ(At(found.points(), k), Vector3(contact.point().x(), contact.point().y(), contact.point().z()));
      EXPECT_EQ(At(found.normals(), k), Vector3(contact.normal().x(), contact.normal().y(), contact.normal().z()));
      ++k;
    }
  }
  EXPECT_EQ(k, found.objects_size());
  EXPECT_GT(k, 100);
  EXPECT_GT(several, 5);

  // one radius for every centre answers as that radius given to each
  query->clear_radii();
  query->add_radii(0.1);
  const v1::ContactsBatch shared = harness.Call(batch).contacts_batch();
  for (int i = 0; i < 400; ++i) {
    v1::Request single;
    SetVec3(centers[i], single.mutable_find_contacts()->mutable_center());
    single.mutable_find_contacts()->set_radius(0.1);
    ASSERT_EQ(static_cast<int>(shared.counts(i)), harness.Call(single).contacts().contacts_size()) << i;
  }
}

TEST(PointBatches, AFanOfRaysFromOneOriginAnswersAsRaysWithTheirOwnOrigins) {
  Harness harness;
  AddMeshesAndSphere(harness);
  std::mt19937_64 random(8);
  std::normal_distribution<double> turn(0, 1);
  v1::Request fan;
  v1::Request each;
  fan.mutable_ray_cast_batch()->set_max_distance(10);
  each.mutable_ray_cast_batch()->set_max_distance(10);
  const Vector3 origin(0.01, 0.02, 0.2);
  for (int k = 0; k < 3; ++k) fan.mutable_ray_cast_batch()->add_origins(origin[k]);
  for (int i = 0; i < 300; ++i) {
    const Vector3 direction(turn(random), turn(random), turn(random));
    for (int k = 0; k < 3; ++k) {
      fan.mutable_ray_cast_batch()->add_directions(direction[k]);
      each.mutable_ray_cast_batch()->add_directions(direction[k]);
      each.mutable_ray_cast_batch()->add_origins(origin[k]);
    }
  }
  const v1::Reply from_one = harness.Call(fan);
  const v1::Reply from_each = harness.Call(each);
  ASSERT_TRUE(from_one.has_ray_hits()) << from_one.error().message();
  EXPECT_EQ(from_one.ray_hits().SerializeAsString(), from_each.ray_hits().SerializeAsString());
  EXPECT_EQ(from_one.ray_hits().hit_size(), 300);
  int hits = 0;
  for (const bool hit : from_one.ray_hits().hit()) hits += hit;
  EXPECT_GT(hits, 100);

  // two origins for three directions is neither shape
  v1::Request ragged;
  for (int k = 0; k < 6; ++k) ragged.mutable_ray_cast_batch()->add_origins(k);
  for (int k = 0; k < 9; ++k) ragged.mutable_ray_cast_batch()->add_directions(1);
  ragged.mutable_ray_cast_batch()->set_max_distance(1);
  ExpectError(harness.Call(ragged), v1::Error::CODE_BAD_REQUEST,
              "ray_cast_batch has 6 origin and 9 direction values; it needs x, y, z of each, and one origin for "
              "every direction or one per direction");
}

TEST(PointBatches, BadValuesAndBoundsAreRefusedByName) {
  Harness harness;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  v1::Request closest;
  v1::ClosestPointBatch* points = closest.mutable_closest_point_batch();
  for (const double v : {0.0, 0.0, 0.5, 1.0, nan, 0.0}) points->add_points(v);
  points->set_max_distance(1);
  ExpectError(harness.Call(closest), v1::Error::CODE_BAD_REQUEST,
              "closest_point_batch.points[1] is [1, nan, 0]; every point must be finite");
  points->set_points(4, 2);
  points->set_max_distance(0);
  ExpectError(harness.Call(closest), v1::Error::CODE_BAD_REQUEST,
              "closest_point_batch.max_distance is 0; it must be a finite number > 0");
  points->set_max_distance(1);
  points->add_points(3);
  ExpectError(harness.Call(closest), v1::Error::CODE_BAD_REQUEST,
              "closest_point_batch.points has 7 values; it needs x, y, z of each point");
  points->mutable_points()->Resize(3 * (kMaxBatchPoints + 1), 0.5);
  ExpectError(harness.Call(closest), v1::Error::CODE_BAD_REQUEST,
              "closest_point_batch.points has 1000001 points; at most 1000000 are served in one request");
  // no points: no answers
  points->clear_points();
  const v1::Reply none = harness.Call(closest);
  ASSERT_TRUE(none.has_closest_points());
  EXPECT_EQ(none.closest_points().found_size(), 0);

  v1::Request contacts;
  v1::FindContactsBatch* spheres = contacts.mutable_find_contacts_batch();
  for (const double v : {0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0}) spheres->add_centers(v);
  spheres->add_radii(0.1);
  spheres->add_radii(0.2);
  ExpectError(harness.Call(contacts), v1::Error::CODE_BAD_REQUEST,
              "find_contacts_batch.radii has 2 values for 3 centers; it needs one for every center or one per "
              "center");
  spheres->add_radii(-std::numeric_limits<double>::infinity());
  ExpectError(harness.Call(contacts), v1::Error::CODE_BAD_REQUEST,
              "find_contacts_batch.radii[2] is -inf; it must be a finite number >= 0");
  spheres->set_radii(2, 0);
  spheres->set_centers(8, std::numeric_limits<double>::infinity());
  ExpectError(harness.Call(contacts), v1::Error::CODE_BAD_REQUEST,
              "find_contacts_batch.centers[2] is [2, 0, inf]; every point must be finite");
  spheres->clear_radii();
  spheres->set_centers(8, 0);
  ExpectError(harness.Call(contacts), v1::Error::CODE_BAD_REQUEST,
              "find_contacts_batch.radii has 0 values for 3 centers; it needs one for every center or one per "
              "center");

  // more contacts than one reply holds: each of these centres touches the box and the floor
  spheres->clear_centers();
  const int n = static_cast<int>(kMaxBatchContacts / 2) + 1;
  spheres->mutable_centers()->Resize(3 * n, 0.0);
  spheres->add_radii(1.0);
  ExpectError(harness.Call(contacts), v1::Error::CODE_RESOURCE_EXHAUSTED,
              "find_contacts_batch finds more than 1000000 contacts for its 500001 centers, the most one reply "
              "holds; ask fewer centers or a smaller radius");
}

TEST(PointBatches, AnObserverMayAskThem) {
  Harness harness;
  harness.connection.role = Role::kObserver;
  v1::Request closest;
  for (int k = 0; k < 3; ++k) closest.mutable_closest_point_batch()->add_points(0);
  closest.mutable_closest_point_batch()->set_max_distance(1);
  const v1::Reply nearest = harness.Call(closest);
  ASSERT_TRUE(nearest.has_closest_points()) << nearest.error().message();
  // the origin is the box's centre: 0.05 m inside it
  EXPECT_EQ(nearest.closest_points().signed_distance(0), -0.05);
  EXPECT_EQ(NameOf(nearest.closest_points().object_names(), nearest.closest_points().objects(0)), "box");
  v1::Request contacts;
  for (int k = 0; k < 3; ++k) contacts.mutable_find_contacts_batch()->add_centers(0);
  contacts.mutable_find_contacts_batch()->add_radii(0);
  EXPECT_TRUE(harness.Call(contacts).has_contacts_batch());
}

}  // namespace
}  // namespace hapticd::net
