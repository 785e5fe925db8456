// The proxy methods against the penalty baseline: thin objects, friction, force
// shading and objects that move.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "server/force/render_session.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::force {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

constexpr double kHalfThickness = 0.0005;  // a 1 mm plate

SessionSettings Settings(ForceMethod method, double radius) {
  SessionSettings settings;
  settings.avatar.type = radius > 0 ? AvatarType::kSphere : AvatarType::kPoint;
  settings.avatar.radius = radius;
  settings.avatar.method = method;
  settings.device.max_force = 1000;
  return settings;
}

struct StrokeResult {
  double lowest_avatar_z = 1;       // the avatar's lowest centre height
  bool force_ever_downwards = false;  // the plate pulled the device through
  Vector3 final_force = Vector3::Zero();
};

// A device stroke straight down through the plate at 1 m/s (1 mm per 1 ms tick), from
// 20 mm above to 20 mm below, then held there. The device is driven, not simulated:
// this is the geometry of the method, the worst case for it.
StrokeResult Stroke(const scene::SceneSnapshot& scene, ForceMethod method, double radius,
                    const Vector3& xy, double phase = 0) {
  RenderSession session(Settings(method, radius));
  const Vector3 start = xy + Vector3(0, 0, 0.02 - phase);
  session.Reset(start);
  StrokeResult result;
  for (int tick = 0; tick <= 60; ++tick) {
    DeviceInput input;
    input.p_WD = start - std::min(tick, 40) * Vector3(0, 0, 0.001);
    input.v_WD = tick < 40 ? Vector3(0, 0, -1) : Vector3::Zero();
    const TickOutput out = session.Tick(scene, input, 0.001);
    result.lowest_avatar_z = std::min(result.lowest_avatar_z, out.avatar_W.z());
    result.force_ever_downwards |= out.f_W.z() < 0;
    result.final_force = out.f_W;
  }
  return result;
}

std::vector<scene::ObjectSpec> Plates() {
  const scene::Material material = MakeMaterial(2000);
  return {MakeObject("box_plate", scene::BoxShape{Vector3(0.1, 0.1, kHalfThickness)}, Vector3::Zero(), material),
          MakeObject("mesh_plate", MeshOf(geometry::MakeBoxMesh(Vector3(0.1, 0.1, kHalfThickness), 3)),
                     Vector3::Zero(), material)};
}

TEST(PopThrough, ProxiesNeverCrossAOneMillimetrePlateAtOneMetrePerSecond) {
  // points aimed at a face, an interior edge and an interior vertex of the mesh plate
  const std::vector<Vector3> aims = {Vector3(0.0123, 0.0371, 0), Vector3(0.1 / 3, 0.01, 0),
                                     Vector3(0.1 / 3, 0.1 / 3, 0), Vector3(0, 0, 0)};
  for (const scene::ObjectSpec& plate : Plates()) {
    auto scene = BuildScene({plate});
    for (const Vector3& aim : aims) {
      for (const auto& [method, radius] :
           {std::pair{ForceMethod::kGodObject, 0.0}, std::pair{ForceMethod::kFingerProxy, 0.004}}) {
        SCOPED_TRACE(plate.name + " " + std::string(ForceMethodName(method)));
        const StrokeResult r = Stroke(*scene, method, radius, aim);
        EXPECT_GE(r.lowest_avatar_z, kHalfThickness + radius - 1e-8);
        EXPECT_FALSE(r.force_ever_downwards);
        // held 20 mm under the top: the proxy pulls the device back up with k d
        EXPECT_NEAR(r.final_force.z(), 2000 * (0.02 + kHalfThickness + radius), 1e-3);
      }
    }
  }
}

// The failure the stability maps chart: past the plate's middle the penalty method's
// nearest surface is the bottom one, so it pulls the device through and then lets go.
TEST(PopThrough, PenaltyPopsThroughTheSamePlate) {
  for (const scene::ObjectSpec& plate : Plates()) {
    SCOPED_TRACE(plate.name);
    auto scene = BuildScene({plate});
    // whatever the phase of the 1 mm samples against the plate, nothing holds the
    // device once it is through
    for (double phase : {0.0, 0.0001, 0.0003, 0.0005, 0.0008}) {
      const StrokeResult r = Stroke(*scene, ForceMethod::kPenalty, 0, Vector3(0.0123, 0.0371, 0), phase);
      EXPECT_EQ(r.final_force, Vector3::Zero()) << "phase " << phase;
      EXPECT_LT(r.lowest_avatar_z, -0.019);
    }
    // a sample in the plate's lower half is pushed on through
    const StrokeResult r = Stroke(*scene, ForceMethod::kPenalty, 0, Vector3(0.0123, 0.0371, 0), 0.0003);
    EXPECT_TRUE(r.force_ever_downwards);
  }
}

// Friction: pressed to depth d, the device moves sideways. Inside the static cone
// (tangential offset <= mu_s d) the proxy sticks; beyond it, it slides with the
// tangential force mu_d times the normal force.
TEST(Friction, SticksInsideTheConeAndSlidesWithTheDynamicCoefficient) {
  constexpr double kK = 2000, kDepth = 0.002, kStatic = 0.6, kDynamic = 0.4;
  for (const auto& [method, radius] :
       {std::pair{ForceMethod::kGodObject, 0.0}, std::pair{ForceMethod::kFingerProxy, 0.005}}) {
    SCOPED_TRACE(ForceMethodName(method));
    auto scene = BuildScene({MakeObject("floor", scene::PlaneShape{}, Vector3::Zero(),
                                        MakeMaterial(kK, 0, kStatic, kDynamic))});
    RenderSession session(Settings(method, radius));
    session.Reset(Vector3(0, 0, radius + 0.003));
    DeviceInput input;
    // press straight down
    for (int i = 0; i <= 5; ++i) {
      input.p_WD = Vector3(0, 0, radius + 0.003 - i * 0.001);
      session.Tick(*scene, input, 0.001);
    }
    // drag sideways by 10 micrometres per tick up to 4 mm
    bool slid = false;
    for (int i = 1; i <= 400; ++i) {
      const double x = i * 1e-5;
      input.p_WD = Vector3(x, 0, radius - kDepth);
      const TickOutput out = session.Tick(*scene, input, 0.001);
      const double normal = out.f_W.z(), tangential = -out.f_W.x();
      ASSERT_NEAR(normal, kK * kDepth, 1e-5);
      if (x <= kStatic * kDepth - 2e-5) {
        // sticking: the proxy has not moved, the spring holds the whole offset
        EXPECT_NEAR(out.avatar_W.x(), 0, 1e-12) << "x = " << x;
        EXPECT_NEAR(tangential, kK * x, 1e-6);
      } else if (x >= kStatic * kDepth + 2e-5) {
        slid = true;
        EXPECT_NEAR(tangential / normal, kDynamic, 0.01 * kDynamic) << "x = " << x;
        EXPECT_GT(out.avatar_W.x(), 0);
      }
    }
    EXPECT_TRUE(slid);
  }
}

// Force shading turns the force of a faceted sphere towards the smooth normal.
TEST(ForceShading, FollowsTheInterpolatedNormalOnACoarseMeshSphere) {
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(2, 0.05);
  scene::Material material = MakeMaterial(2000);
  auto scene = BuildScene({MakeObject("ball", MeshOf(ball), Vector3::Zero(), material)});
  // a direction off the middle of a facet, where facet and sphere normals differ
  const geometry::Triangle t = ball.triangle(7);
  const Vector3 on_facet = 0.6 * t.v0 + 0.3 * t.v1 + 0.1 * t.v2;
  const Vector3 radial = on_facet.normalized();
  const Vector3 facet_normal = (t.v1 - t.v0).cross(t.v2 - t.v0).normalized();
  double error_flat = 0, error_shaded = 0;
  for (bool shading : {false, true}) {
    SessionSettings settings = Settings(ForceMethod::kGodObject, 0);
    settings.avatar.force_shading = shading;
    RenderSession session(settings);
    session.Reset(on_facet + 0.005 * facet_normal);
    TickOutput out;
    for (int i = 0; i <= 7; ++i) {
      DeviceInput input;
      input.p_WD = on_facet + (0.005 - std::min(i, 7) * 0.001) * facet_normal;
      out = session.Tick(*scene, input, 0.001);
    }
    const double angle = std::acos(std::clamp(out.f_W.normalized().dot(radial), -1.0, 1.0));
    (shading ? error_shaded : error_flat) = angle;
    EXPECT_GT(out.f_W.dot(facet_normal), 0);
  }
  // flat: the facet's normal; shaded: much closer to the sphere's
  EXPECT_NEAR(error_flat, std::acos(facet_normal.dot(radial)), 1e-6);
  EXPECT_LT(error_shaded, 0.5 * error_flat);
}

// Sliding around a finely tessellated sphere, pressed in: the proxy glides over the
// triangles' shared edges (no constraint overflow, no sticking) and the force turns
// smoothly with the surface.
TEST(Sliding, FingerProxyGlidesOverAMeshSphere) {
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(40, 0.05);
  auto scene = BuildScene({MakeObject("ball", MeshOf(ball), Vector3::Zero(), MakeMaterial(2000))});
  for (double radius : {0.0, 0.005}) {
    SCOPED_TRACE(radius);
    RenderSession session(Settings(radius > 0 ? ForceMethod::kFingerProxy : ForceMethod::kGodObject, radius));
    const double orbit = 0.05 + radius - 0.001;
    session.Reset(Vector3(orbit + 0.01, 0, 0));
    Vector3 previous = Vector3::Zero();
    double largest_turn = 0;
    for (int tick = 0; tick < 800; ++tick) {
      const double angle = 0.004 * tick;  // 0.2 m/s
      DeviceInput input;
      input.p_WD = orbit * Vector3(std::cos(angle), std::sin(angle) * 0.96, std::sin(angle) * 0.28);
      const TickOutput out = session.Tick(*scene, input, 0.001);
      if (tick > 10) {
        ASSERT_TRUE(out.contact) << tick;
        // pressed 1 mm in: about k d, within the tessellation's sagitta
        EXPECT_NEAR(out.f_W.norm(), 2.0, 0.05) << tick;
        largest_turn = std::max(largest_turn, std::acos(std::clamp(
            out.f_W.normalized().dot(previous.normalized()), -1.0, 1.0)));
      }
      previous = out.f_W;
    }
    EXPECT_EQ(session.counters().constraint_overflows, 0u);
    // the orbit turns 0.004 rad per tick, and crossing an edge turns the (unshaded) normal
    // by the facets' dihedral angle, about 0.028 rad at this tessellation
    EXPECT_LT(largest_turn, 0.05);
  }
}

// A kinematic box moving into a resting proxy pushes it (and the device feels it).
TEST(KinematicObjects, AMovingBoxPushesAProxyItRunsInto) {
  scene::SceneBuilder builder;
  scene::ObjectSpec box = MakeObject("pusher", scene::BoxShape{Vector3(0.02, 0.02, 0.02)},
                                     Vector3(-0.03, 0, 0), MakeMaterial(1000));
  box.motion = scene::Motion::kKinematic;
  box.v_WB = Vector3(0.05, 0, 0);
  builder.Add(box);
  RenderSession session(Settings(ForceMethod::kGodObject, 0));
  session.Reset(Vector3::Zero());
  DeviceInput input;  // the device held still at the origin
  double pushed = 0;
  for (int tick = 1; tick <= 400; ++tick) {
    const Vector3 centre(-0.03 + tick * 0.05e-3, 0, 0);
    builder.MoveKinematic("pusher", scene::Pose{geometry::Matrix3::Identity(), centre}, box.v_WB, Vector3::Zero());
    auto scene = builder.Build(tick);
    const TickOutput out = session.Tick(*scene, input, 0.001);
    const double face = centre.x() + 0.02;
    // the proxy is never inside the box
    EXPECT_GE(out.avatar_W.x(), face - 1e-8) << "tick " << tick;
    if (face > 0) {
      EXPECT_NEAR(out.f_W.x(), 1000 * face, 1e-4) << "tick " << tick;
      pushed = out.f_W.x();
    }
  }
  EXPECT_GT(pushed, 0.9);
}

// A proxy resting on a kinematic box with friction is carried along by it.
TEST(KinematicObjects, AProxyRestingWithFrictionIsCarriedAlong) {
  scene::SceneBuilder builder;
  scene::ObjectSpec table = MakeObject("table", scene::BoxShape{Vector3(0.1, 0.1, 0.01)},
                                       Vector3(0, 0, -0.01), MakeMaterial(1000, 0, 1.0, 0.8));
  table.motion = scene::Motion::kKinematic;
  table.v_WB = Vector3(0.01, 0, 0);
  builder.Add(table);
  RenderSession session(Settings(ForceMethod::kGodObject, 0));
  session.Reset(Vector3(0, 0, 0.002));
  DeviceInput input;
  input.p_WD = Vector3(0, 0, -0.002);  // pressed 2 mm in; friction holds up to 2 mm sideways
  TickOutput out;
  for (int tick = 1; tick <= 100; ++tick) {
    builder.MoveKinematic("table", scene::Pose{geometry::Matrix3::Identity(), Vector3(tick * 1e-5, 0, -0.01)},
                          table.v_WB, Vector3::Zero());
    out = session.Tick(*builder.Build(tick), input, 0.001);
  }
  // carried 1 mm with the table (inside the cone: 1 mm < mu_s * 2 mm)
  EXPECT_NEAR(out.avatar_W.x(), 1e-3, 2e-5);
  EXPECT_NEAR(out.f_W.x(), 1000 * 1e-3, 0.03);
}

// A rising plate whose snapshots step a little more than a tick carries the proxy resting
// on it (another thread moved it, on its own clock: 10 um plus up to 1.6 nm a tick) holds
// the proxy on its top every tick: one left inside by less than the skin is pushed out
// too, not dropped through to the device.
TEST(KinematicObjects, APlateSteppingPastTheCarryNeverDropsTheProxy) {
  for (const double radius : {0.0, 0.003}) {
    scene::SceneBuilder builder;
    scene::ObjectSpec table = MakeObject("table", scene::BoxShape{Vector3(0.1, 0.1, 0.01)}, Vector3(0, 0, -0.01),
                                         MakeMaterial(1000));
    table.motion = scene::Motion::kKinematic;
    table.v_WB = Vector3(0, 0, 0.01);
    builder.Add(table);
    RenderSession session(Settings(radius > 0 ? ForceMethod::kFingerProxy : ForceMethod::kGodObject, radius));
    session.Reset(Vector3(0, 0, radius + 0.001));
    DeviceInput input;
    input.p_WD = Vector3(0, 0, radius - 0.002);  // 2 mm into the top at first
    double top = 0;
    for (int tick = 1; tick <= 200; ++tick) {
      top += 1e-5 + (tick % 5) * 0.4e-9;
      builder.MoveKinematic("table", scene::Pose{geometry::Matrix3::Identity(), Vector3(0, 0, top - 0.01)},
                            table.v_WB, Vector3::Zero());
      const TickOutput out = session.Tick(*builder.Build(tick), input, 0.001);
      ASSERT_NEAR(out.f_W.z(), 1000 * (top + 0.002), 1e-5) << "radius " << radius << ", tick " << tick;
    }
  }
}

}  // namespace
}  // namespace hapticd::force
