// Static contact: an avatar pressed to depth d into a surface feels F = k d along the
// surface normal, for every force method, avatar type and shape type.

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

constexpr double kStiffness = 2000;
constexpr double kDepth = 0.002;

// One pressing case: a surface point of the scene's only object and its outward normal.
struct PressCase {
  std::string name;
  scene::ObjectSpec object;
  Vector3 surface_point;
  Vector3 normal;
  double tolerance;  // relative, on |F - k d n| / (k d)
};

std::vector<PressCase> MakeCases() {
  const scene::Material material = MakeMaterial(kStiffness);
  const Vector3 up = Vector3::UnitZ();
  const Vector3 oblique = Vector3(1, -2, 2).normalized();
  std::vector<PressCase> cases;
  cases.push_back({"plane", MakeObject("plane", scene::PlaneShape{}, Vector3::Zero(), material),
                   Vector3(0.3, -0.2, 0), up, 0.01});
  cases.push_back({"box_face",
                   MakeObject("box", scene::BoxShape{Vector3(0.1, 0.1, 0.05)}, Vector3(0, 0, -0.05), material),
                   Vector3(0.02, 0.03, 0), up, 0.01});
  cases.push_back({"box_side",
                   MakeObject("box", scene::BoxShape{Vector3(0.1, 0.1, 0.05)}, Vector3::Zero(), material),
                   Vector3(0.1, 0.01, 0.02), Vector3::UnitX(), 0.01});
  cases.push_back({"sphere_top",
                   MakeObject("ball", scene::SphereShape{0.05}, Vector3(0, 0, -0.05), material),
                   Vector3::Zero(), up, 0.01});
  cases.push_back({"sphere_oblique",
                   MakeObject("ball", scene::SphereShape{0.05}, Vector3(0.1, 0.2, 0.3), material),
                   Vector3(0.1, 0.2, 0.3) + 0.05 * oblique, oblique, 0.01});
  cases.push_back({"capsule_side",
                   MakeObject("capsule", scene::CapsuleShape{0.03, 0.1}, Vector3::Zero(), material),
                   Vector3(0, 0.03, 0.05), Vector3::UnitY(), 0.01});
  scene::ConvexSpec octahedron;
  for (int k = 0; k < 3; ++k) {
    octahedron.points.push_back(0.1 * Vector3::Unit(k));
    octahedron.points.push_back(-0.1 * Vector3::Unit(k));
  }
  const Vector3 face_normal = Vector3(1, 1, 1).normalized();
  cases.push_back({"convex_face", MakeObject("octahedron", octahedron, Vector3::Zero(), material),
                   Vector3::Constant(0.1 / 3), face_normal, 0.01});
  // a mesh sphere, pressed through the middle of a triangle: within its tessellation
  // error (sagitta ~8e-6 m at frequency 32, 0.4% of the depth) of the analytic sphere
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(32, 0.05);
  const geometry::Triangle t0 = ball.triangle(0);
  const Vector3 radial = (t0.v0 + t0.v1 + t0.v2).normalized();
  cases.push_back({"mesh_sphere", MakeObject("mesh_ball", MeshOf(ball), Vector3::Zero(), material),
                   0.05 * radial, radial, 0.015});
  cases.push_back({"mesh_box",
                   MakeObject("mesh_box", MeshOf(geometry::MakeBoxMesh(Vector3(0.1, 0.1, 0.05), 4)),
                              Vector3(0, 0, -0.05), material),
                   Vector3(0.013, -0.021, 0), up, 0.01});
  return cases;
}

struct MethodCase {
  ForceMethod method;
  AvatarType type;
  double radius;
};

SessionSettings MakeSettings(const MethodCase& m) {
  SessionSettings settings;
  settings.avatar.type = m.type;
  settings.avatar.radius = m.radius;
  settings.avatar.method = m.method;
  settings.device.max_force = 100;
  return settings;
}

// Approach from 5 mm outside along the normal in 1 mm steps, then hold at depth d.
Vector3 PressAndHold(const PressCase& c, const MethodCase& m, TickOutput* last) {
  auto scene = BuildScene({c.object});
  RenderSession session(MakeSettings(m));
  const Vector3 contact_centre = c.surface_point + m.radius * c.normal;
  session.Reset(contact_centre + 0.005 * c.normal);
  for (int step = 0; step <= 7; ++step) {
    DeviceInput input;
    input.p_WD = contact_centre + (0.005 - std::min(step * 0.001, 0.005 + kDepth)) * c.normal;
    if (step == 7) input.p_WD = contact_centre - kDepth * c.normal;
    *last = session.Tick(*scene, input, 0.001);
  }
  return last->f_W;
}

TEST(StaticContact, ForceIsStiffnessTimesDepthAlongTheNormal) {
  const std::vector<MethodCase> methods = {
      {ForceMethod::kPenalty, AvatarType::kPoint, 0},
      {ForceMethod::kGodObject, AvatarType::kPoint, 0},
      {ForceMethod::kPenalty, AvatarType::kSphere, 0.005},
      {ForceMethod::kFingerProxy, AvatarType::kSphere, 0.005},
  };
  for (const PressCase& c : MakeCases()) {
    for (const MethodCase& m : methods) {
      SCOPED_TRACE(c.name + " " + std::string(ForceMethodName(m.method)) + " r=" +
                   std::to_string(m.radius));
      TickOutput out;
      const Vector3 f = PressAndHold(c, m, &out);
      const Vector3 expected = kStiffness * kDepth * c.normal;
      EXPECT_LE((f - expected).norm(), c.tolerance * expected.norm()) << f.transpose();
      EXPECT_TRUE(out.contact);
      EXPECT_EQ(out.touched_object, 0);
    }
  }
}

TEST(StaticContact, ProxyRestsOnTheSurfaceWhileTheDeviceIsInside) {
  for (const PressCase& c : MakeCases()) {
    SCOPED_TRACE(c.name);
    TickOutput out;
    PressAndHold(c, {ForceMethod::kGodObject, AvatarType::kPoint, 0}, &out);
    EXPECT_LE((out.avatar_W - c.surface_point).norm(), 0.01 * kDepth + 1e-5)
        << out.avatar_W.transpose();
  }
}

TEST(StaticContact, NoForceOutsideAndProxyFollowsTheDevice) {
  auto scene = BuildScene({MakeObject("plane", scene::PlaneShape{}, Vector3::Zero(), MakeMaterial(kStiffness))});
  for (const MethodCase& m : {MethodCase{ForceMethod::kGodObject, AvatarType::kPoint, 0},
                              MethodCase{ForceMethod::kFingerProxy, AvatarType::kSphere, 0.01},
                              MethodCase{ForceMethod::kPenalty, AvatarType::kPoint, 0}}) {
    RenderSession session(MakeSettings(m));
    session.Reset(Vector3(0, 0, 0.05));
    DeviceInput input;
    input.p_WD = Vector3(0.01, 0.02, 0.03);
    const TickOutput out = session.Tick(*scene, input, 0.001);
    EXPECT_EQ(out.f_W, Vector3::Zero());
    EXPECT_FALSE(out.contact);
    EXPECT_LE((out.avatar_W - input.p_WD).norm(), 1e-12);
  }
}

// Touching exactly (the device on the surface) gives zero force but no crossing.
TEST(StaticContact, DampingOpposesTheNormalVelocityOnlyInside) {
  auto scene = BuildScene(
      {MakeObject("plane", scene::PlaneShape{}, Vector3::Zero(), MakeMaterial(kStiffness, 3.0))});
  RenderSession session(MakeSettings({ForceMethod::kPenalty, AvatarType::kPoint, 0}));
  session.Reset(Vector3(0, 0, 0.01));
  DeviceInput input;
  input.p_WD = Vector3(0, 0, -0.001);
  input.v_WD = Vector3(0, 0, -0.1);
  const TickOutput pressing = session.Tick(*scene, input, 0.001);
  EXPECT_NEAR(pressing.f_W.z(), kStiffness * 0.001 + 3.0 * 0.1, 1e-9);
  // leaving fast: the damper would pull; the force is clamped at zero instead
  input.v_WD = Vector3(0, 0, 1.0);
  const TickOutput leaving = session.Tick(*scene, input, 0.001);
  EXPECT_EQ(leaving.f_W.z(), 0.0);
}

}  // namespace
}  // namespace hapticd::force
