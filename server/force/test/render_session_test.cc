// The session around the force methods: admittance, bad input, the watchdog, limits.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "server/force/render_session.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::force {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::shared_ptr<const scene::SceneSnapshot> Floor() {
  return BuildScene({MakeObject("floor", scene::PlaneShape{}, Vector3::Zero(), MakeMaterial(2000))});
}

SessionSettings Admittance(double radius) {
  SessionSettings settings;
  settings.avatar.type = radius > 0 ? AvatarType::kSphere : AvatarType::kPoint;
  settings.avatar.radius = radius;
  settings.avatar.method = radius > 0 ? ForceMethod::kFingerProxy : ForceMethod::kGodObject;
  settings.device.mode = DeviceMode::kAdmittance;
  settings.device.max_force = 20;
  settings.admittance.virtual_mass = 1.0;
  settings.admittance.virtual_damping = 20;
  return settings;
}

// Pushed with 10 N into a wall: the avatar reaches it, settles on the surface and
// never passes it.
TEST(Admittance, PushedIntoAWallItSettlesOnTheSurface) {
  auto scene = Floor();
  for (double radius : {0.0, 0.01}) {
    RenderSession session(Admittance(radius));
    session.Reset(Vector3(0.01, 0.02, radius + 0.05));
    DeviceInput input;
    input.f_sensed_W = Vector3(0, 0, -10);
    double lowest = 1;
    TickOutput out;
    for (int tick = 0; tick < 2000; ++tick) {
      out = session.Tick(*scene, input, 0.001);
      lowest = std::min(lowest, out.p_command_W.z());
    }
    EXPECT_GE(lowest, radius);
    EXPECT_NEAR(out.p_command_W.z(), radius, 1e-8);
    EXPECT_TRUE(out.contact);
    // it did not slide: the push was straight down
    EXPECT_NEAR(out.p_command_W.x(), 0.01, 1e-12);
  }
}

// Free of contact the avatar is a mass-damper: terminal speed f / b.
TEST(Admittance, FreeAvatarReachesTheTerminalSpeed) {
  auto scene = BuildScene({});
  RenderSession session(Admittance(0));
  session.Reset(Vector3::Zero());
  DeviceInput input;
  input.f_sensed_W = Vector3(4, 0, 0);
  Vector3 previous = Vector3::Zero();
  TickOutput out;
  for (int tick = 0; tick < 1000; ++tick) {
    previous = out.p_command_W;
    out = session.Tick(*scene, input, 0.001);
  }
  EXPECT_NEAR((out.p_command_W.x() - previous.x()) / 0.001, 4.0 / 20, 1e-6);
}

TEST(Admittance, SlidesAlongAnObliquePush) {
  auto scene = Floor();
  RenderSession session(Admittance(0));
  session.Reset(Vector3(0, 0, 0.001));
  DeviceInput input;
  input.f_sensed_W = Vector3(2, 0, -10);
  TickOutput out;
  for (int tick = 0; tick < 1000; ++tick) out = session.Tick(*scene, input, 0.001);
  EXPECT_GE(out.p_command_W.z(), 0);
  EXPECT_GT(out.p_command_W.x(), 0.05);  // the tangential push moves it along the floor
}

SessionSettings Impedance(ForceMethod method) {
  SessionSettings settings;
  settings.avatar.method = method;
  settings.device.max_force = 8;
  return settings;
}

// NaN, infinite and absurd samples are counted and ignored: the force stays the last
// safe one, and the session carries on when good samples return.
TEST(BadInput, NonFiniteAndAbsurdSamplesAreCountedAndIgnored) {
  auto scene = Floor();
  for (ForceMethod method : {ForceMethod::kPenalty, ForceMethod::kGodObject}) {
    RenderSession session(Impedance(method));
    session.Reset(Vector3(0, 0, 0.01));
    DeviceInput good;
    good.p_WD = Vector3(0, 0, 0.01);
    session.Tick(*scene, good, 0.001);
    good.p_WD = Vector3(0, 0, -0.001);
    const TickOutput pressing = session.Tick(*scene, good, 0.001);
    ASSERT_NEAR(pressing.f_W.z(), 2.0, 1e-5);

    DeviceInput bad = good;
    bad.p_WD = Vector3(kNaN, 0, 0);
    TickOutput out = session.Tick(*scene, bad, 0.001);
    EXPECT_TRUE(out.f_W.allFinite());
    EXPECT_NEAR(out.f_W.z(), 2.0, 1e-5);
    bad = good;
    bad.v_WD = Vector3(0, std::numeric_limits<double>::infinity(), 0);
    out = session.Tick(*scene, bad, 0.001);
    EXPECT_NEAR(out.f_W.z(), 2.0, 1e-5);
    bad = good;
    bad.p_WD = Vector3(1e9, 0, 0);  // a kilometre-scale jump: absurd
    out = session.Tick(*scene, bad, 0.001);
    EXPECT_NEAR(out.f_W.z(), 2.0, 1e-5);
    EXPECT_EQ(session.counters().nonfinite_inputs, 2u);
    EXPECT_EQ(session.counters().absurd_inputs, 1u);
    out = session.Tick(*scene, good, 0.001);
    EXPECT_NEAR(out.f_W.z(), 2.0, 1e-5);
  }
}

TEST(BadInput, AbsurdForcesAreSaturatedToTheDeviceLimit) {
  auto scene = BuildScene({MakeObject("floor", scene::PlaneShape{}, Vector3::Zero(), MakeMaterial(1e7))});
  RenderSession session(Impedance(ForceMethod::kGodObject));
  session.Reset(Vector3(0, 0, 0.01));
  DeviceInput input;
  input.p_WD = Vector3(0.001, 0, -0.05);
  const TickOutput out = session.Tick(*scene, input, 0.001);
  EXPECT_NEAR(out.f_W.norm(), 8.0, 1e-9);
  EXPECT_GT(out.f_W.z(), 0);
  EXPECT_EQ(session.counters().force_saturations, 1u);
  // an absurd sensed force in admittance mode is ignored, the avatar does not fly off
  RenderSession admittance(Admittance(0));
  admittance.Reset(Vector3(0, 0, 0.1));
  DeviceInput push;
  push.f_sensed_W = Vector3(0, 0, -1e7);
  const TickOutput held = admittance.Tick(*scene, push, 0.001);
  EXPECT_EQ(held.p_command_W, Vector3(0, 0, 0.1));
  EXPECT_EQ(admittance.counters().absurd_inputs, 1u);
}

TEST(BadInput, AnEmptySceneRendersNothing) {
  auto empty = BuildScene({});
  for (ForceMethod method : {ForceMethod::kPenalty, ForceMethod::kGodObject}) {
    RenderSession session(Impedance(method));
    session.Reset(Vector3::Zero());
    DeviceInput input;
    input.p_WD = Vector3(0.1, -0.2, 0.3);
    const TickOutput out = session.Tick(*empty, input, 0.001);
    EXPECT_EQ(out.f_W, Vector3::Zero());
    EXPECT_FALSE(out.contact);
    EXPECT_EQ(out.avatar_W, input.p_WD);
  }
}

TEST(BadInput, ADegenerateMeshIsRefusedByTheScene) {
  scene::MeshSpec flat;
  flat.vertices = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(2, 0, 0)};
  flat.triangles = {{0, 1, 2}};
  scene::SceneBuilder builder;
  try {
    builder.Add(MakeObject("sliver", flat, Vector3::Zero(), MakeMaterial(1000)));
    FAIL() << "a mesh of zero-area triangles was accepted";
  } catch (const scene::SceneError& error) {
    EXPECT_NE(std::string(error.what()).find("objects[sliver]"), std::string::npos) << error.what();
  }
  EXPECT_EQ(builder.num_objects(), 0);
}

TEST(BadInput, BadSettingsAreRefusedWithTheFieldNamed) {
  SessionSettings settings;
  settings.device.max_force = kNaN;
  try {
    RenderSession session(settings);
    FAIL();
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("device.max_force"), std::string::npos) << error.what();
  }
}

// When samples stop, the force ramps to zero (not a step), and comes back with them.
TEST(Watchdog, ForceRampsToZeroWhenSamplesStop) {
  auto scene = Floor();
  SessionSettings settings = Impedance(ForceMethod::kGodObject);
  settings.control.watchdog_timeout_s = 0.01;
  settings.control.watchdog_ramp_s = 0.02;
  RenderSession session(settings);
  session.Reset(Vector3(0, 0, 0.01));
  DeviceInput input;
  input.p_WD = Vector3(0, 0, -0.001);
  const double pressing = session.Tick(*scene, input, 0.001).f_W.z();
  ASSERT_NEAR(pressing, 2.0, 1e-5);
  input.fresh = false;
  double previous = pressing;
  for (int tick = 1; tick <= 40; ++tick) {
    const TickOutput output = session.Tick(*scene, input, 0.001);
    const double f = output.f_W.z();
    // before the ramp, the force a fresh sample would bring back at once
    EXPECT_NEAR(output.f_unscaled_W.z(), 2.0, 1e-5);
    if (tick <= 10) {
      EXPECT_NEAR(f, 2.0, 1e-5);
    }
    EXPECT_LE(f, previous + 1e-12);
    EXPECT_LE(previous - f, pressing * 0.001 / 0.02 + 1e-9);  // never faster than the ramp
    previous = f;
  }
  EXPECT_EQ(previous, 0.0);
  EXPECT_EQ(session.counters().watchdog_trips, 1u);
  input.fresh = true;
  EXPECT_NEAR(session.Tick(*scene, input, 0.001).f_W.z(), 2.0, 1e-5);
}

}  // namespace
}  // namespace hapticd::force

namespace hapticd::force {
namespace {

// Every value that passes validation keeps the tick finite: sessions and scenes drawn
// at and between the ends of their documented ranges (SessionLimits, SceneLimits), and
// device input anywhere inside the workspace, give finite commands within the force
// limit. Before the ranges, a sphere of radius 1e308 rendered 0 N deep inside it and a
// sphere avatar of radius 1e308 got NaN coordinates.
TEST(Limits, EveryValueThatPassesKeepsTheTickFinite) {
  using SL = SessionLimits;
  using GL = scene::SceneLimits;
  std::mt19937_64 rng(41);
  // a value at either end of [low, high] or log-uniform between
  auto pick = [&](double low, double high) {
    const int which = std::uniform_int_distribution<int>(0, 3)(rng);
    if (which == 0) return low;
    if (which == 1) return high;
    return std::exp(std::uniform_real_distribution<double>(std::log(low), std::log(high))(rng));
  };
  auto signed_pick = [&](double low, double high) {
    return (std::uniform_int_distribution<int>(0, 1)(rng) ? 1 : -1) * pick(low, high);
  };
  auto position = [&](double bound) {
    return Vector3(signed_pick(1e-6, bound), signed_pick(1e-6, bound), signed_pick(1e-6, bound));
  };
  int contacts = 0;
  for (int trial = 0; trial < 400; ++trial) {
    // a scene of one big or small object somewhere within range
    const scene::Material material = MakeMaterial(pick(1, GL::kMaxStiffness), pick(1e-3, GL::kMaxDamping),
                                                  pick(1e-3, GL::kMaxFriction), 0);
    scene::ShapeSpec shape;
    switch (trial % 4) {
      case 0: shape = scene::SphereShape{pick(1e-6, GL::kMaxSize)}; break;
      case 1: shape = scene::BoxShape{Vector3(pick(1e-6, GL::kMaxSize), pick(1e-6, GL::kMaxSize),
                                              pick(1e-6, GL::kMaxSize))}; break;
      case 2: shape = scene::CapsuleShape{pick(1e-6, GL::kMaxSize), pick(1e-6, GL::kMaxSize)}; break;
      default: shape = scene::PlaneShape{}; break;
    }
    const Vector3 centre = trial % 8 < 4 ? Vector3::Zero() : position(GL::kMaxCoordinate);
    const auto scene = BuildScene({MakeObject("thing", shape, centre, material)});

    // a session anywhere within its ranges
    SessionSettings settings;
    const bool sphere = std::uniform_int_distribution<int>(0, 1)(rng);
    settings.avatar.type = sphere ? AvatarType::kSphere : AvatarType::kPoint;
    settings.avatar.radius = sphere ? pick(1e-6, SL::kMaxAvatarRadius) : 0;
    const int method = std::uniform_int_distribution<int>(0, 1)(rng);
    settings.avatar.method = method == 0 ? ForceMethod::kPenalty
                             : sphere    ? ForceMethod::kFingerProxy
                                         : ForceMethod::kGodObject;
    settings.device.mode = trial % 3 == 0 ? DeviceMode::kAdmittance : DeviceMode::kImpedance;
    settings.device.max_force = pick(1e-3, SL::kMaxForce);
    settings.device.max_velocity = pick(1e-3, SL::kMaxVelocity);
    settings.device.rate_hz = pick(SL::kMinRateHz, SL::kMaxRateHz);
    settings.admittance.virtual_mass = pick(SL::kMinVirtualMass, SL::kMaxVirtualMass);
    settings.admittance.virtual_damping = pick(1e-3, SL::kMaxVirtualDamping);
    settings.control.passivity = trial % 5 == 0;
    ASSERT_FALSE(ValidateSessionSettings(settings).has_value()) << *ValidateSessionSettings(settings);

    RenderSession session(settings);
    session.Reset(position(50));
    for (int tick = 0; tick < 20; ++tick) {
      DeviceInput input;
      // inside the workspace, and at times deep inside the object
      input.p_WD = tick % 2 ? position(50) : centre.cwiseMin(50).cwiseMax(-50);
      input.v_WD = position(settings.device.max_velocity) / std::sqrt(3.0);
      input.f_sensed_W = position(settings.device.max_force) / std::sqrt(3.0);
      const TickOutput out = session.Tick(*scene, input, 1 / settings.device.rate_hz);
      SCOPED_TRACE(::testing::Message() << "trial " << trial << " tick " << tick);
      ASSERT_TRUE(out.f_W.allFinite()) << out.f_W.transpose();
      ASSERT_TRUE(out.p_command_W.allFinite()) << out.p_command_W.transpose();
      ASSERT_TRUE(out.avatar_W.allFinite()) << out.avatar_W.transpose();
      ASSERT_LE(out.f_W.norm(), settings.device.max_force * (1 + 1e-12));
      contacts += out.contact ? 1 : 0;
    }
  }
  // the draw reached inside objects often enough to mean something
  EXPECT_GT(contacts, 1000);
}

// A huge sphere still pushes a device that is deep inside it out, along its radius.
TEST(Limits, TheLargestSpherePushesOutFromDeepInside) {
  const double r = scene::SceneLimits::kMaxSize;
  const auto scene = BuildScene({MakeObject("ball", scene::SphereShape{r}, Vector3(0, 0, -r), MakeMaterial(1000))});
  SessionSettings settings;
  settings.avatar.method = ForceMethod::kPenalty;
  settings.device.max_force = 100;
  RenderSession session(settings);
  session.Reset(Vector3(0, 0, 0.01));
  DeviceInput input;
  input.p_WD = Vector3(0, 0, -0.02);
  const TickOutput out = session.Tick(*scene, input, 0.001);
  EXPECT_NEAR(out.f_W.z(), 20, 1e-6);
  EXPECT_NEAR(out.f_W.head<2>().norm(), 0, 1e-9);
}

}  // namespace
}  // namespace hapticd::force
