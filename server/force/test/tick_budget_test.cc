// A tick that spends its work budget (an overrun) is thrown away: the avatar stays, the
// force is the last safe one, the overrun is counted, a stream of them costs a quarter
// budget a tick and ramps the force down like a silent device's. On both ray backends.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "server/force/render_session.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::force {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;

constexpr int kStackTriangles = 20000;
constexpr int64_t kBudget = 2000;

// n different triangles in the plane z = 0 with one and the same box, 20 cm across (a
// fan whose apex slides along the box's top edge): no BVH splits them, so any query
// near the plane visits them all.
scene::MeshSpec UnsplittableStack(int n) {
  scene::MeshSpec mesh;
  mesh.vertices = {{-0.1, -0.1, 0}, {0.1, -0.1, 0}};
  for (int i = 0; i < n; ++i) {
    mesh.vertices.push_back({-0.1 + 0.2 * i / (n - 1), 0.1, 0});
    mesh.triangles.push_back({0, 1, i + 2});
  }
  mesh.pin = scene::Representation::kMesh;
  return mesh;
}

// A box (its -x face at x = 0.9) at x = 1 and the stack at x = -1.
std::shared_ptr<const scene::SceneSnapshot> MakeScene(scene::RayBackend backend) {
  std::vector<scene::ObjectSpec> specs = {
      MakeObject("box", scene::BoxShape{Vector3::Constant(0.1)}, {1, 0, 0}, MakeMaterial(1000)),
      MakeObject("stack", UnsplittableStack(kStackTriangles), {-1, 0, 0}, MakeMaterial(1000)),
  };
  specs[1].ray_backend = backend;
  return BuildScene(specs);
}

DeviceInput At(const Vector3& p) {
  DeviceInput input;
  input.p_WD = p;
  return input;
}

class TickBudget : public ::testing::TestWithParam<scene::RayBackend> {};

TEST_P(TickBudget, AnOverrunSendsTheLastSafeForceAndAStreamOfThemRampsDown) {
  const auto scene = MakeScene(GetParam());
  const SessionSettings settings;  // god-object, watchdog 50 ms then a 100 ms ramp
  RenderSession session(settings, kBudget);
  session.Reset({0.85, 0, 0.05});
  // 1 mm into the box's -x face: 1 N towards -x (and the way to the stack leaves the
  // face, so the proxy's sweep there must meet the stack)
  const Vector3 on_box(0.901, 0, 0.05);
  TickOutput safe;
  for (int i = 0; i < 50; ++i) safe = session.Tick(*scene, At(on_box), 1e-3);
  ASSERT_FALSE(safe.overrun);
  ASSERT_NEAR(safe.f_W.x(), -1.0, 1e-5);
  ASSERT_LE(session.last_tick_work(), kBudget);
  EXPECT_EQ(session.counters().tick_overruns, 0u);

  // through the stack: every tick overruns; the first repeats the last safe force
  // exactly and leaves the proxy where it was
  const Vector3 in_stack(-1, 0.02, -0.001);
  const TickOutput first = session.Tick(*scene, At(in_stack), 1e-3);
  EXPECT_TRUE(first.overrun);
  EXPECT_GT(session.last_tick_work(), kBudget);
  EXPECT_EQ(first.f_W, safe.f_W);
  EXPECT_EQ(first.avatar_W, safe.avatar_W);
  EXPECT_EQ(session.counters().tick_overruns, 1u);
  // overruns count as silence: after the watchdog's 50 ms the force ramps to zero
  double last_norm = first.f_W.norm();
  TickOutput out = first;
  // and the bucket, emptied by the first, refills by a quarter budget a tick: that is
  // all each later overrun may spend (give or take one BVH leaf)
  for (int i = 0; i < 200; ++i) {
    out = session.Tick(*scene, At(in_stack), 1e-3);
    ASSERT_TRUE(out.overrun) << i;
    ASSERT_LE(session.last_tick_work(), kBudget / 4 + 8) << i;
    ASSERT_EQ(out.avatar_W, safe.avatar_W) << i;
    ASSERT_LE(out.f_W.norm(), last_norm) << i;
    last_norm = out.f_W.norm();
  }
  EXPECT_EQ(out.f_W, Vector3::Zero());
  EXPECT_EQ(session.counters().tick_overruns, 201u);
  EXPECT_EQ(session.counters().watchdog_trips, 1u);

  // back on the box: rendering resumes from where the proxy stayed
  for (int i = 0; i < 5; ++i) out = session.Tick(*scene, At(on_box), 1e-3);
  EXPECT_FALSE(out.overrun);
  EXPECT_NEAR(out.f_W.x(), -1.0, 1e-5);
  EXPECT_EQ(session.counters().tick_overruns, 201u);
}

// The same moves with a budget nothing reaches: no overrun, so the budget (not the
// path) made them.
TEST_P(TickBudget, WithoutABudgetTheSameTicksDoNotOverrun) {
  const auto scene = MakeScene(GetParam());
  RenderSession session(SessionSettings{}, int64_t{1} << 40);
  session.Reset({0.85, 0, 0.05});
  for (int i = 0; i < 50; ++i) session.Tick(*scene, At({0.901, 0, 0.05}), 1e-3);
  const TickOutput out = session.Tick(*scene, At({-1, 0.02, -0.001}), 1e-3);
  EXPECT_FALSE(out.overrun);
  EXPECT_GT(session.last_tick_work(), kStackTriangles);
  EXPECT_EQ(session.counters().tick_overruns, 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, TickBudget,
                         ::testing::Values(scene::RayBackend::kNative, scene::RayBackend::kEmbree),
                         [](const auto& info) { return info.param == scene::RayBackend::kNative ? "native" : "embree"; });

TEST(TickBudgetSettings, ABudgetMustBePositive) {
  EXPECT_THROW(RenderSession(SessionSettings{}, 0), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::force
