#include "server/net/model_codec.h"

#include <algorithm>
#include <functional>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/proto_convert.h"
#include "server/net/request_error.h"
#include "server/net/test/count_allocations.h"

namespace hapticd::net {
namespace {

using scene::ObjectSpec;

scene::Pose MakePose(const Vector3& axis, double angle, const Vector3& p_WB) {
  scene::Pose pose;
  pose.rotation = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  pose.translation = p_WB;
  return pose;
}

scene::Material MakeMaterial(double stiffness, double damping, double mu_s, double mu_d, bool shading) {
  return {.stiffness = stiffness, .damping = damping, .static_friction = mu_s, .dynamic_friction = mu_d,
          .force_shading = shading};
}

// A static object at the origin of the default material.
ObjectSpec MakeObject(const std::string& name, const scene::ShapeSpec& shape) {
  ObjectSpec spec;
  spec.name = name;
  spec.shape = shape;
  return spec;
}

// One object of every shape, a mesh pinned and one not, a kinematic one moving.
remote::LocalModel MakeModel() {
  remote::LocalModel model;
  model.version = 0x0123456789abcdefull;
  model.t_s = 12.345678901234567;
  model.center_W = {0.1, -0.2, 0.30000000000000004};
  model.radius = 0.0625;
  model.settings.tolerance = 2.5e-4;
  model.left_out = 3;

  ObjectSpec sphere = MakeObject("ball", scene::SphereShape{0.02});
  sphere.X_WB.translation = {0.1, -0.2, 0.31};
  sphere.material = MakeMaterial(1500, 0.5, 0.4, 0.3, true);

  ObjectSpec box = MakeObject("cart", scene::BoxShape{{0.05, 0.04, 0.03}});
  box.X_WB = MakePose({1, 2, 3}, 0.7, {0.12, -0.18, 0.27});
  box.material = MakeMaterial(3000, 2, 0.6, 0.45, false);
  box.motion = scene::Motion::kKinematic;
  box.v_WB = {0.01, -0.02, 0.003};
  box.w_WB = {0, 0, 0.25};

  ObjectSpec capsule = MakeObject("handle", scene::CapsuleShape{0.01, 0.04});
  capsule.X_WB = MakePose({0, 1, 0}, -1.2, {0.08, -0.2, 0.3});

  ObjectSpec plane = MakeObject("floor", scene::PlaneShape{});
  plane.X_WB.translation = {0, 0, 0.25};
  plane.material = MakeMaterial(5000, 0, 1, 0.8, true);

  ObjectSpec convex =
      MakeObject("wedge", scene::ConvexSpec{{{0, 0, 0}, {0.02, 0, 0}, {0, 0.03, 0}, {0, 0, 0.04}, {0.01, 0.01, 0.01}}});
  convex.X_WB = MakePose({1, 0, 0}, 0.3, {0.1, -0.15, 0.29});

  scene::MeshSpec tetra_spec;
  tetra_spec.vertices = {{0, 0, 0}, {0.03, 0, 0}, {0, 0.03, 0}, {0, 0, 0.03}};
  tetra_spec.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  tetra_spec.pin = scene::Representation::kMesh;
  ObjectSpec pinned = MakeObject("patch", tetra_spec);
  pinned.X_WB = MakePose({1, 1, 0}, 2.0, {0.11, -0.21, 0.32});
  pinned.material = MakeMaterial(800, 0.1, 0.2, 0.1, false);
  tetra_spec.pin = scene::Representation::kAuto;
  ObjectSpec mesh = MakeObject("tetra", tetra_spec);

  model.objects = {sphere, box, capsule, plane, convex, pinned, mesh};
  return model;
}

std::span<const uint8_t> AsBytes(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

void ExpectSameShape(const scene::ShapeSpec& a, const scene::ShapeSpec& b) {
  ASSERT_EQ(a.index(), b.index());
  if (const auto* s = std::get_if<scene::SphereShape>(&a)) {
    EXPECT_EQ(std::get<scene::SphereShape>(b).radius, s->radius);
  } else if (const auto* s = std::get_if<scene::BoxShape>(&a)) {
    EXPECT_EQ(std::get<scene::BoxShape>(b).half_extents, s->half_extents);
  } else if (const auto* s = std::get_if<scene::CapsuleShape>(&a)) {
    EXPECT_EQ(std::get<scene::CapsuleShape>(b).radius, s->radius);
    EXPECT_EQ(std::get<scene::CapsuleShape>(b).half_length, s->half_length);
  } else if (const auto* s = std::get_if<scene::ConvexSpec>(&a)) {
    EXPECT_EQ(std::get<scene::ConvexSpec>(b).points, s->points);
  } else if (const auto* s = std::get_if<scene::MeshSpec>(&a)) {
    const auto& m = std::get<scene::MeshSpec>(b);
    EXPECT_EQ(m.vertices, s->vertices);
    EXPECT_EQ(m.triangles, s->triangles);
    EXPECT_EQ(m.pin, s->pin);
  }
}

void ExpectSameObject(const ObjectSpec& a, const ObjectSpec& b) {
  SCOPED_TRACE(a.name);
  EXPECT_EQ(b.name, a.name);
  ExpectSameShape(a.shape, b.shape);
  EXPECT_EQ(b.X_WB.translation, a.X_WB.translation);
  // the rotation travels as a quaternion: equal to rounding
  EXPECT_LE((b.X_WB.rotation - a.X_WB.rotation).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(b.material.stiffness, a.material.stiffness);
  EXPECT_EQ(b.material.damping, a.material.damping);
  EXPECT_EQ(b.material.static_friction, a.material.static_friction);
  EXPECT_EQ(b.material.dynamic_friction, a.material.dynamic_friction);
  EXPECT_EQ(b.material.force_shading, a.material.force_shading);
  EXPECT_EQ(b.motion, a.motion);
  EXPECT_EQ(b.v_WB, a.v_WB);
  EXPECT_EQ(b.w_WB, a.w_WB);
  // a device renders a model natively
  EXPECT_EQ(b.ray_backend, scene::RayBackend::kNative);
}

TEST(LocalModelCodec, EveryShapeRoundTrips) {
  const remote::LocalModel model = MakeModel();
  const std::string encoded = EncodeLocalModel(model);
  const remote::LocalModel back = DecodeLocalModel(AsBytes(encoded));
  EXPECT_EQ(back.version, model.version);
  EXPECT_EQ(back.t_s, model.t_s);
  EXPECT_EQ(back.center_W, model.center_W);
  EXPECT_EQ(back.radius, model.radius);
  EXPECT_EQ(back.settings.tolerance, model.settings.tolerance);
  EXPECT_EQ(back.settings.ray_backend, scene::RayBackend::kNative);
  EXPECT_EQ(back.left_out, model.left_out);
  ASSERT_EQ(back.objects.size(), model.objects.size());
  for (std::size_t i = 0; i < model.objects.size(); ++i) ExpectSameObject(model.objects[i], back.objects[i]);
}

// Convex objects of 400 points each (about 9.6 kB): a dozen do not fit in kMaxModelBytes.
TEST(LocalModelCodec, AModelTooLongLeavesOutItsLastObjects) {
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> coordinate(-0.05, 0.05);
  remote::LocalModel model = MakeModel();
  model.objects.clear();
  model.left_out = 2;
  constexpr int kObjects = 12;
  for (int i = 0; i < kObjects; ++i) {
    scene::ConvexSpec hull;
    for (int k = 0; k < 400; ++k) hull.points.emplace_back(coordinate(random), coordinate(random), coordinate(random));
    model.objects.push_back(MakeObject("hull" + std::to_string(i), hull));
  }
  const std::string encoded = EncodeLocalModel(model);
  EXPECT_LE(encoded.size(), kMaxModelBytes);

  const remote::LocalModel back = DecodeLocalModel(AsBytes(encoded));
  const int kept = static_cast<int>(back.objects.size());
  ASSERT_GT(kept, 0);
  ASSERT_LT(kept, kObjects);
  EXPECT_EQ(back.left_out, 2 + kObjects - kept);
  for (int i = 0; i < kept; ++i) ExpectSameObject(model.objects[i], back.objects[i]);

  // The cut is the longest prefix that fits: the same bytes as a model of just those
  // objects with the rest counted, and one object more does not fit.
  remote::LocalModel prefix = model;
  prefix.objects.resize(kept);
  prefix.left_out = back.left_out;
  EXPECT_EQ(EncodeLocalModel(prefix), encoded);
  prefix.objects.push_back(model.objects[kept]);
  prefix.left_out = back.left_out - 1;
  EXPECT_EQ(EncodeLocalModel(prefix), encoded);
}

// The RequestError's message, or "" when decoding does not throw one.
std::string DecodeError(std::span<const uint8_t> bytes) {
  try {
    DecodeLocalModel(bytes);
  } catch (const RequestError& error) {
    EXPECT_EQ(error.code(), v1::Error::CODE_BAD_REQUEST);
    return error.what();
  }
  return "";
}

TEST(LocalModelCodec, GarbageIsRefusedWithItsSize) {
  // an objects field claiming 127 bytes of 1
  const std::vector<uint8_t> truncated = {0x32, 0x7f, 0x01};
  EXPECT_EQ(DecodeError(truncated), "local_model: 3 bytes that do not parse as a hapticd.v1.LocalModel");
  // nothing at all is a model of version 0
  EXPECT_EQ(DecodeError({}), "local_model.version is 0; models count from 1");
}

TEST(LocalModelCodec, ABadFieldIsNamed) {
  struct Case {
    std::function<void(v1::LocalModel&)> spoil;
    std::string expected;  // a prefix of the message
  };
  const std::vector<Case> cases = {
      {[](v1::LocalModel& m) { m.set_version(0); }, "local_model.version is 0"},
      {[](v1::LocalModel& m) { m.set_radius(2); }, "local_model.radius is 2; it must be in (0, 1]"},
      {[](v1::LocalModel& m) { m.set_tolerance(0); }, "local_model.tolerance is 0; it must be a finite number > 0"},
      {[](v1::LocalModel& m) { m.mutable_center()->set_y(std::nan("")); }, "local_model.center is [0.1, nan, "},
      {[](v1::LocalModel& m) { m.mutable_objects(1)->clear_shape(); }, "local_model.objects[1].shape is missing"},
      {[](v1::LocalModel& m) { m.mutable_objects(2)->mutable_shape()->Clear(); },
       "local_model.objects[2].shape is not set; it must be one of sphere, box, capsule, plane, convex, mesh"},
      {[](v1::LocalModel& m) { m.mutable_objects(0)->clear_name(); },
       "local_model.objects[0].name is empty; every object needs a name"},
      {[](v1::LocalModel& m) { m.mutable_objects(3)->mutable_material()->set_stiffness(-5); },
       "local_model.objects[3].material.stiffness is -5"},
      {[](v1::LocalModel& m) { m.mutable_objects(6)->mutable_shape()->mutable_mesh()->set_triangles(4, 9); },
       "local_model.objects[6].shape.mesh.triangles[4] is 9; the mesh has 4 vertices"},
      {[](v1::LocalModel& m) { m.mutable_objects(4)->mutable_shape()->mutable_convex()->add_points(1); },
       "local_model.objects[4].shape.convex.points has 16 values"},
      {[](v1::LocalModel& m) { WriteVector({0, 0, 1}, m.mutable_objects(0)->mutable_velocity()); },
       "local_model.objects[0] is static but has a velocity"},
      {[](v1::LocalModel& m) {
         while (m.objects_size() <= remote::kMaxModelObjects) *m.add_objects() = m.objects(0);
       },
       "local_model.objects has 65 objects; a model holds at most 64"},
  };
  const std::string encoded = EncodeLocalModel(MakeModel());
  for (const Case& c : cases) {
    v1::LocalModel message;
    ASSERT_TRUE(message.ParseFromString(encoded));
    c.spoil(message);
    const std::string spoiled = message.SerializeAsString();
    const std::string error = DecodeError(AsBytes(spoiled));
    EXPECT_EQ(error.substr(0, c.expected.size()), c.expected) << error;
  }
}

TEST(ModelFragments, CountCoversTheBytesInChunks) {
  EXPECT_EQ(FragmentCount(0), 1u);  // an empty encoding still travels, in one
  EXPECT_EQ(FragmentCount(1), 1u);
  EXPECT_EQ(FragmentCount(kModelChunkSize), 1u);
  EXPECT_EQ(FragmentCount(kModelChunkSize + 1), 2u);
  EXPECT_EQ(FragmentCount(2 * kModelChunkSize), 2u);
  EXPECT_EQ(FragmentCount(kMaxModelBytes - 1), kMaxModelFragments);
  EXPECT_EQ(FragmentCount(kMaxModelBytes), kMaxModelFragments);
}

std::vector<uint8_t> RandomBytes(std::size_t size, std::mt19937_64& random) {
  std::vector<uint8_t> bytes(size);
  for (auto& byte : bytes) byte = static_cast<uint8_t>(random());
  return bytes;
}

TEST(ModelFragments, FragmentsTileTheEncoding) {
  std::mt19937_64 random(1);
  for (const std::size_t size : {std::size_t{0}, std::size_t{1}, kModelChunkSize, kModelChunkSize + 1,
                                 std::size_t{2500}, kMaxModelBytes}) {
    SCOPED_TRACE(size);
    const std::vector<uint8_t> encoded = RandomBytes(size, random);
    const uint32_t count = FragmentCount(size);
    std::size_t at = 0;
    for (uint32_t i = 0; i < count; ++i) {
      const ModelFragmentView fragment = Fragment(encoded, 9, i);
      EXPECT_EQ(fragment.version, 9u);
      EXPECT_EQ(fragment.index, i);
      EXPECT_EQ(fragment.count, count);
      // each a view of the encoding, full chunks but the last
      EXPECT_EQ(fragment.data.data(), encoded.data() + at);
      EXPECT_EQ(fragment.data.size(), i + 1 < count ? kModelChunkSize : size - at);
      at += fragment.data.size();
    }
    EXPECT_EQ(at, size);
  }
}

// Offers each fragment in order; true when exactly the last one completes the model.
bool OfferInOrder(ModelAssembler& assembler, std::span<const uint8_t> encoded, uint64_t version) {
  const uint32_t count = FragmentCount(encoded.size());
  for (uint32_t i = 0; i < count; ++i) {
    if (assembler.Offer(Fragment(encoded, version, i)) != (i + 1 == count)) return false;
  }
  return true;
}

bool SameBytes(std::span<const uint8_t> a, std::span<const uint8_t> b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end());
}

TEST(ModelAssembler, PutsAnEncodedModelBackTogether) {
  // a model of several fragments: one mesh of 300 vertices (7.2 kB)
  remote::LocalModel model = MakeModel();
  scene::MeshSpec fan;
  fan.vertices.push_back(Vector3::Zero());
  for (int i = 0; i < 299; ++i) {
    fan.vertices.emplace_back(0.01 * std::cos(i * 0.02), 0.01 * std::sin(i * 0.02), 0);
    if (i > 0) fan.triangles.push_back({0, i, i + 1});
  }
  model.objects.push_back(MakeObject("fan", fan));
  const std::string encoded = EncodeLocalModel(model);
  ASSERT_GT(FragmentCount(encoded.size()), 7u);

  ModelAssembler assembler;
  EXPECT_TRUE(OfferInOrder(assembler, AsBytes(encoded), model.version));
  EXPECT_EQ(assembler.version(), model.version);
  EXPECT_TRUE(SameBytes(assembler.bytes(), AsBytes(encoded)));
  EXPECT_EQ(DecodeLocalModel(assembler.bytes()).objects.size(), model.objects.size());
  EXPECT_EQ(assembler.rejected(), 0u);
}

// Random orders, fixed seed, sizes at the chunk boundaries: the model completes on the
// last fragment missing and not before; one assembler takes version after version.
TEST(ModelAssembler, CompletesInAnyOrderOnTheLastMissingFragment) {
  std::mt19937_64 random(17);
  ModelAssembler assembler;
  uint64_t version = 0;
  for (const std::size_t size : {std::size_t{0}, std::size_t{1}, kModelChunkSize - 1, kModelChunkSize,
                                 kModelChunkSize + 1, std::size_t{5000}, kMaxModelBytes - 1, kMaxModelBytes}) {
    for (int trial = 0; trial < 5; ++trial) {
      SCOPED_TRACE(::testing::Message() << "size " << size << ", trial " << trial);
      const std::vector<uint8_t> encoded = RandomBytes(size, random);
      const uint32_t count = FragmentCount(size);
      std::vector<uint32_t> order(count);
      std::iota(order.begin(), order.end(), 0u);
      std::shuffle(order.begin(), order.end(), random);
      ++version;
      for (uint32_t k = 0; k < count; ++k) {
        ASSERT_EQ(assembler.Offer(Fragment(encoded, version, order[k])), k + 1 == count) << "fragment " << order[k];
      }
      EXPECT_EQ(assembler.version(), version);
      EXPECT_TRUE(SameBytes(assembler.bytes(), encoded));
    }
  }
  EXPECT_EQ(assembler.rejected(), 0u);
}

TEST(ModelAssembler, DuplicatesChangeNothing) {
  std::mt19937_64 random(23);
  ModelAssembler assembler;
  const std::vector<uint8_t> encoded = RandomBytes(10 * kModelChunkSize + 77, random);
  const uint32_t count = FragmentCount(encoded.size());
  // every fragment two or three times, shuffled
  std::vector<uint32_t> offers;
  for (uint32_t i = 0; i < count; ++i) offers.insert(offers.end(), 2 + random() % 2, i);
  std::shuffle(offers.begin(), offers.end(), random);
  std::set<uint32_t> have;
  int completions = 0;
  for (const uint32_t index : offers) {
    const bool completes = have.insert(index).second && have.size() == count;
    const bool completed = assembler.Offer(Fragment(encoded, 4, index));
    EXPECT_EQ(completed, completes) << "fragment " << index;
    completions += completed;
  }
  EXPECT_EQ(completions, 1);
  EXPECT_TRUE(SameBytes(assembler.bytes(), encoded));
  EXPECT_EQ(assembler.rejected(), 0u);
}

TEST(ModelAssembler, ANewerVersionDropsTheOlderAndTheOlderIsIgnored) {
  std::mt19937_64 random(29);
  const std::vector<uint8_t> older = RandomBytes(3 * kModelChunkSize - 5, random);
  const std::vector<uint8_t> newer = RandomBytes(kModelChunkSize + 9, random);
  ModelAssembler assembler;
  EXPECT_FALSE(assembler.Offer(Fragment(older, 1, 0)));
  EXPECT_FALSE(assembler.Offer(Fragment(older, 1, 1)));
  // version 2 starts over: its two fragments complete it, whatever of 1 arrives between
  EXPECT_FALSE(assembler.Offer(Fragment(newer, 2, 1)));
  EXPECT_FALSE(assembler.Offer(Fragment(older, 1, 2)));
  EXPECT_EQ(assembler.version(), 2u);
  EXPECT_TRUE(assembler.Offer(Fragment(newer, 2, 0)));
  EXPECT_TRUE(SameBytes(assembler.bytes(), newer));
  // a whole older model, arriving late, neither completes nor disturbs the newer one
  for (uint32_t i = 0; i < 3; ++i) EXPECT_FALSE(assembler.Offer(Fragment(older, 1, i)));
  // nor does a repeat of the one completed
  EXPECT_FALSE(assembler.Offer(Fragment(newer, 2, 1)));
  EXPECT_EQ(assembler.version(), 2u);
  EXPECT_TRUE(SameBytes(assembler.bytes(), newer));
  // the older ones are stale, not malformed
  EXPECT_EQ(assembler.rejected(), 0u);
}

TEST(ModelAssembler, RejectsFragmentsOfTheWrongShape) {
  std::mt19937_64 random(31);
  const std::vector<uint8_t> encoded = RandomBytes(3 * kModelChunkSize - 100, random);
  const std::vector<uint8_t> spare = RandomBytes(kModelChunkSize + 1, random);
  ModelAssembler assembler;
  EXPECT_FALSE(assembler.Offer(Fragment(encoded, 5, 0)));

  // Each refused and counted; the gathering of version 5 goes on (a malformed fragment
  // of a newer version does not drop it).
  ModelFragmentView bad = Fragment(encoded, 5, 1);
  bad.data = bad.data.first(kModelChunkSize - 1);  // short, not the last
  EXPECT_FALSE(assembler.Offer(bad));
  EXPECT_EQ(assembler.rejected(), 1u);
  bad = Fragment(encoded, 5, 2);
  bad.data = spare;  // the last, longer than a chunk
  EXPECT_FALSE(assembler.Offer(bad));
  bad = Fragment(encoded, 5, 1);
  bad.count = 4;  // another count than version 5's first fragment said
  EXPECT_FALSE(assembler.Offer(bad));
  bad = Fragment(encoded, 6, 0);
  bad.data = bad.data.first(10);
  EXPECT_FALSE(assembler.Offer(bad));
  bad = Fragment(encoded, 7, 0);
  bad.index = 3;  // not below its count
  EXPECT_FALSE(assembler.Offer(bad));
  bad.count = 0;
  bad.index = 0;
  EXPECT_FALSE(assembler.Offer(bad));
  bad = Fragment(encoded, 8, 0);
  bad.count = kMaxModelFragments + 1;
  EXPECT_FALSE(assembler.Offer(bad));
  EXPECT_EQ(assembler.rejected(), 7u);
  EXPECT_EQ(assembler.version(), 5u);

  EXPECT_FALSE(assembler.Offer(Fragment(encoded, 5, 2)));
  EXPECT_TRUE(assembler.Offer(Fragment(encoded, 5, 1)));
  EXPECT_TRUE(SameBytes(assembler.bytes(), encoded));
  EXPECT_EQ(assembler.rejected(), 7u);
}

TEST(ModelAssembler, OfferAllocatesNothing) {
  std::mt19937_64 random(37);
  const std::vector<uint8_t> big = RandomBytes(kMaxModelBytes, random);
  const std::vector<uint8_t> small = RandomBytes(kModelChunkSize + 3, random);
  ModelAssembler assembler;
  bool all_completed = true;
  const long before = hapticd::testing::AllocationCount();
  for (uint64_t version = 1; version <= 20; ++version) {
    all_completed &= OfferInOrder(assembler, version % 2 ? big : small, version);
  }
  EXPECT_EQ(hapticd::testing::AllocationCount() - before, 0);
  EXPECT_TRUE(all_completed);
  EXPECT_TRUE(SameBytes(assembler.bytes(), small));
}

}  // namespace
}  // namespace hapticd::net
