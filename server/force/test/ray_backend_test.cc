// A mesh on the Embree backend renders exactly as on the native one: the backend only
// changes which code picks candidate triangles, never the exact tests that decide.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/embree/embree_mesh.h"
#include "server/force/render_session.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::force {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

// An icosphere (r 0.05) and a torus (0.04, 0.012) side by side, on the given backend.
std::shared_ptr<const scene::SceneSnapshot> MakeMeshScene(scene::RayBackend backend) {
  std::vector<scene::ObjectSpec> specs = {
      MakeObject("ball", MeshOf(geometry::MakeIcosphere(8, 0.05)), {0, 0, 0}, MakeMaterial(1500, 2, 0.4, 0.3)),
      MakeObject("ring", MeshOf(geometry::MakeTorus(0.04, 0.012, 48, 24)), {0.15, 0, 0}, MakeMaterial(2500)),
  };
  for (auto& spec : specs) spec.ray_backend = backend;
  return BuildScene(specs);
}

// The device's path: onto the ball's top and 3 mm into it, across, up and over to the
// ring, down 3 mm into its tube and along it, with a little fixed-seed jitter so the
// proxy meets edges and vertices anywhere.
std::vector<DeviceInput> MakePath() {
  const std::vector<Vector3> waypoints = {{-0.03, 0, 0.06},      {-0.03, 0, 0.0447}, {0.03, 0.005, 0.0447},
                                          {0.03, 0, 0.07},       {0.11, 0, 0.03},    {0.11, 0, 0.009},
                                          {0.112, 0.006, 0.009}};
  constexpr int kTicksPerLeg = 500;
  std::mt19937_64 random(11);
  std::normal_distribution<double> jitter(0, 2e-4);
  std::vector<DeviceInput> path;
  for (std::size_t leg = 0; leg + 1 < waypoints.size(); ++leg) {
    for (int i = 0; i < kTicksPerLeg; ++i) {
      const double s = static_cast<double>(i) / kTicksPerLeg;
      DeviceInput input;
      input.p_WD = (1 - s) * waypoints[leg] + s * waypoints[leg + 1];
      input.p_WD += Vector3(jitter(random), jitter(random), jitter(random));
      input.v_WD = (waypoints[leg + 1] - waypoints[leg]) / (kTicksPerLeg * 1e-3);
      path.push_back(input);
    }
  }
  return path;
}

void ExpectSameRendering(const SessionSettings& settings) {
  const auto native = MakeMeshScene(scene::RayBackend::kNative);
  const auto embree = MakeMeshScene(scene::RayBackend::kEmbree);
  ASSERT_EQ(std::get<scene::MeshShape>(native->object(0).shape).embree, nullptr);
  ASSERT_NE(std::get<scene::MeshShape>(embree->object(0).shape).embree, nullptr);
  RenderSession on_native(settings), on_embree(settings);
  on_native.Reset({-0.03, 0, 0.06});
  on_embree.Reset({-0.03, 0, 0.06});
  int contacts = 0;
  for (const DeviceInput& input : MakePath()) {
    const TickOutput a = on_native.Tick(*native, input, 1e-3);
    const TickOutput b = on_embree.Tick(*embree, input, 1e-3);
    ASSERT_EQ(a.contact, b.contact);
    ASSERT_EQ(a.touched_object, b.touched_object);
    // Equal answers give equal forces; ties between triangles at the same point may
    // only reorder a sum, so allow its rounding.
    ASSERT_LT((a.f_W - b.f_W).norm(), 1e-9) << a.f_W.transpose() << " vs " << b.f_W.transpose();
    ASSERT_LT((a.avatar_W - b.avatar_W).norm(), 1e-12);
    contacts += a.contact;
  }
  EXPECT_GT(contacts, 800);  // most of the legs across the ball and along the ring
  EXPECT_EQ(on_native.counters().constraint_overflows, on_embree.counters().constraint_overflows);
}

TEST(RayBackend, GodObjectRendersTheSameOnEmbree) {
  SessionSettings settings;
  settings.device.max_force = 100;
  ExpectSameRendering(settings);
}

TEST(RayBackend, FingerProxyRendersTheSameOnEmbree) {
  SessionSettings settings;
  settings.avatar.type = AvatarType::kSphere;
  settings.avatar.radius = 0.004;
  settings.avatar.method = ForceMethod::kFingerProxy;
  settings.device.max_force = 100;
  ExpectSameRendering(settings);
}

TEST(RayBackend, ThePrimitivesAndTheSceneDefaultFollowTheSettings) {
  scene::SceneSettings settings;
  settings.ray_backend = scene::RayBackend::kEmbree;
  scene::SceneBuilder builder(settings);
  builder.Add(MakeObject("ball", MeshOf(geometry::MakeIcosphere(2, 0.05)), {0, 0, 0}, MakeMaterial(1000)));
  scene::ObjectSpec native = MakeObject("native", MeshOf(geometry::MakeIcosphere(2, 0.05)), {1, 0, 0}, MakeMaterial(1000));
  native.ray_backend = scene::RayBackend::kNative;
  builder.Add(native);
  builder.Add(MakeObject("box", scene::BoxShape{Vector3(0.1, 0.1, 0.1)}, {2, 0, 0}, MakeMaterial(1000)));
  const auto snapshot = builder.Build(1);
  EXPECT_NE(std::get<scene::MeshShape>(snapshot->object(0).shape).embree, nullptr);
  EXPECT_EQ(std::get<scene::MeshShape>(snapshot->object(1).shape).embree, nullptr);
  EXPECT_TRUE(std::holds_alternative<scene::BoxShape>(snapshot->object(2).shape));

  scene::ObjectSpec bad = native;
  bad.name = "bad";
  bad.ray_backend = static_cast<scene::RayBackend>(7);
  try {
    builder.Add(bad);
    FAIL() << "a backend out of range was accepted";
  } catch (const scene::SceneError& e) {
    EXPECT_STREQ(e.what(), "objects[bad].ray_backend is 7; it must be native or embree");
  }
}

}  // namespace
}  // namespace hapticd::force
