// A session that gathers its neighbourhood once a tick renders what one that asks the
// whole scene every query renders (the direct path is the oracle), tick for tick, to
// rounding (where several triangles are touched at once the two may name different
// ones), for
// every proxy method on both ray backends, with friction, force shading and kinematic
// objects; and its ticks allocate nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "server/force/render_session.h"
#include "server/geometry/mesh_generators.h"
#include "server/net/test/count_allocations.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::force {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

// A dense mesh ball (20,480 triangles, about 1.6 mm each, rough enough to catch a
// sphere on its facets), a box beside it, a plane under both, and a kinematic box that
// sweeps through where the device goes.
std::shared_ptr<const scene::SceneSnapshot> MakeScene(scene::RayBackend backend, double friction, bool shading) {
  scene::MeshSpec ball = MeshOf(geometry::MakeIcosphere(32, 0.05));
  ball.pin = scene::Representation::kMesh;
  scene::ObjectSpec mesh = MakeObject("ball", ball, {0, 0, 0}, MakeMaterial(2000, 1, friction, 0.7 * friction));
  mesh.ray_backend = backend;
  mesh.material.force_shading = shading;
  scene::ObjectSpec box = MakeObject("box", scene::BoxShape{Vector3(0.02, 0.02, 0.02)}, {0.07, 0, 0},
                                     MakeMaterial(3000, 0, friction, 0.7 * friction));
  scene::ObjectSpec mover = MakeObject("mover", scene::BoxShape{Vector3(0.01, 0.03, 0.01)}, {-0.09, 0, 0.05},
                                       MakeMaterial(1000));
  mover.motion = scene::Motion::kKinematic;
  mover.v_WB = Vector3(0.05, 0, 0);
  return BuildScene({MakeObject("floor", scene::PlaneShape{}, {0, 0, -0.06}, MakeMaterial(1500)), mesh, box, mover});
}

SessionSettings Settings(ForceMethod method, double radius, bool admittance) {
  SessionSettings settings;
  settings.avatar.type = radius > 0 ? AvatarType::kSphere : AvatarType::kPoint;
  settings.avatar.radius = radius;
  settings.avatar.method = method;
  settings.avatar.force_shading = true;
  settings.device.max_force = 1000;
  if (admittance) settings.device.mode = DeviceMode::kAdmittance;
  return settings;
}

// The device's path at tick k: around and over the ball, pressed in, across to the box
// and back, with a jitter that catches edges at every angle.
DeviceInput At(int k) {
  const double t = 1e-3 * k;
  DeviceInput input;
  const double orbit = 0.053 - 0.004 * std::sin(3 * t);
  input.p_WD = Vector3(orbit * std::cos(2 * t), orbit * std::sin(2 * t) * 0.9, 0.02 * std::sin(5 * t) + 0.01);
  input.v_WD = Vector3(-0.1 * std::sin(2 * t), 0.1 * std::cos(2 * t), 0.1 * std::cos(5 * t));
  input.f_sensed_W = Vector3(-3 * std::cos(2 * t), -3 * std::sin(2 * t), -2 + std::sin(7 * t));
  return input;
}

struct Case {
  ForceMethod method;
  double radius;
  bool admittance;
  double friction;
  scene::RayBackend backend;
};

std::string Name(const Case& c) {
  return std::string(c.admittance ? "admittance" : c.method == ForceMethod::kGodObject ? "god-object" : "finger") +
         " r " + std::to_string(c.radius) + " mu " + std::to_string(c.friction) +
         (c.backend == scene::RayBackend::kEmbree ? " embree" : " native");
}

class GatheredSession : public ::testing::TestWithParam<Case> {};

TEST_P(GatheredSession, RendersWhatTheDirectSessionRendersTickForTick) {
  const Case c = GetParam();
  const auto scene = MakeScene(c.backend, c.friction, true);
  const SessionSettings settings = Settings(c.method, c.radius, c.admittance);
  RenderSession gathered(settings);
  RenderSession direct(settings, kDefaultTickWorkBudget, {0, 0});
  gathered.Reset(At(0).p_WD + Vector3(0, 0, 0.02));
  direct.Reset(At(0).p_WD + Vector3(0, 0, 0.02));
  int contacts = 0, differ = 0;
  double worst_x = 0, worst_f = 0;
  for (int k = 0; k < 3000; ++k) {
    const TickOutput g = gathered.Tick(*scene, At(k), 1e-3);
    const TickOutput d = direct.Tick(*scene, At(k), 1e-3);
    worst_x = std::max(worst_x, (g.avatar_W - d.avatar_W).norm());
    worst_f = std::max(worst_f, (g.f_W - d.f_W).norm());
    differ += g.avatar_W != d.avatar_W;
    contacts += g.contact;
  }
  // of several triangles touched at once the two may name different ones, whose planes
  // differ by rounding: nothing more (the example scenarios' traces are asked to agree to
  // 1e-9 m and 1e-6 N)
  EXPECT_LE(worst_x, 1e-13) << Name(c) << ": " << differ << " ticks differ";
  EXPECT_LE(worst_f, 1e-10) << Name(c) << ": " << differ << " ticks differ";
  EXPECT_GT(contacts, 300) << Name(c);
  EXPECT_EQ(gathered.counters().constraint_overflows, direct.counters().constraint_overflows) << Name(c);
  // the neighbourhood answered most of the queries
  const query::Neighbourhood& near = gathered.neighbourhood();
  EXPECT_GT(near.local_answers(), 4 * near.scene_answers()) << Name(c);
}

INSTANTIATE_TEST_SUITE_P(
    Methods, GatheredSession,
    ::testing::Values(Case{ForceMethod::kFingerProxy, 0.005, false, 0, scene::RayBackend::kNative},
                      Case{ForceMethod::kFingerProxy, 0.005, false, 0, scene::RayBackend::kEmbree},
                      Case{ForceMethod::kFingerProxy, 0.002, false, 0.6, scene::RayBackend::kNative},
                      Case{ForceMethod::kFingerProxy, 0.002, false, 0.6, scene::RayBackend::kEmbree},
                      Case{ForceMethod::kGodObject, 0, false, 0, scene::RayBackend::kNative},
                      Case{ForceMethod::kGodObject, 0, false, 0.6, scene::RayBackend::kEmbree},
                      Case{ForceMethod::kFingerProxy, 0.004, true, 0, scene::RayBackend::kNative},
                      Case{ForceMethod::kFingerProxy, 0.004, true, 0, scene::RayBackend::kEmbree}));

// Ticks of every method that gathers (the sessions made beforehand) make no heap
// allocation (operator new is counted by count_allocations.h; Embree's own heap is not).
TEST(GatheredSession, TicksAllocateNothing) {
  std::vector<RenderSession> sessions;
  for (const scene::RayBackend backend : {scene::RayBackend::kNative, scene::RayBackend::kEmbree}) {
    const auto scene = MakeScene(backend, 0.5, true);
    sessions.clear();
    sessions.emplace_back(Settings(ForceMethod::kFingerProxy, 0.005, false));
    sessions.emplace_back(Settings(ForceMethod::kGodObject, 0, false));
    sessions.emplace_back(Settings(ForceMethod::kFingerProxy, 0.004, true));
    sessions.emplace_back(Settings(ForceMethod::kPenalty, 0.003, false));
    for (RenderSession& session : sessions) session.Reset(At(0).p_WD + Vector3(0, 0, 0.02));
    const long before = hapticd::testing::AllocationCount();
    for (int k = 0; k < 2000; ++k) {
      for (RenderSession& session : sessions) session.Tick(*scene, At(k), 1e-3);
    }
    EXPECT_EQ(hapticd::testing::AllocationCount(), before);
    EXPECT_GT(sessions[0].neighbourhood().local_answers(), 0);
  }
}

}  // namespace
}  // namespace hapticd::force
