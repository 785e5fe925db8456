// The local model against the scene it was cut from: what it holds, and a device
// rendering from it renders as the renderer would from the whole scene; its kinematic
// objects moved by each tick or, allocation-free, by another thread (KinematicMotion).
#include "server/remote/local_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "server/geometry/mesh_generators.h"
#include "server/net/test/count_allocations.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::remote {
namespace {

using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

scene::ObjectSpec Pinned(scene::ObjectSpec spec) {
  std::get<scene::MeshSpec>(spec.shape).pin = scene::Representation::kMesh;
  return spec;
}

// A dense sphere mesh (81,920 triangles, about 1.5 mm across one) under a box, a
// capsule far away and a plane below everything.
std::shared_ptr<const scene::SceneSnapshot> Scene() {
  scene::SceneBuilder builder;
  builder.Add(Pinned(MakeObject("ball", MeshOf(geometry::MakeIcosphere(64, 0.1)), {0, 0, 0}, MakeMaterial(3000))));
  builder.Add(MakeObject("box", scene::BoxShape{Vector3(0.01, 0.01, 0.01)}, {0.02, 0, 0.12}, MakeMaterial(2000)));
  builder.Add(MakeObject("far", scene::CapsuleShape{0.01, 0.02}, {0.5, 0.5, 0.5}, MakeMaterial(1000)));
  builder.Add(MakeObject("floor", scene::PlaneShape{}, {0, 0, -0.2}, MakeMaterial(1000)));
  return builder.Build(7);
}

TEST(LocalModelTest, ModelRadiusCoversTheReachWithinItsCap) {
  EXPECT_DOUBLE_EQ(ModelRadius(0.5, 0.1, 0.01, 0.005), 0.5 * 0.11 + 0.005 + kModelMarginM);
  EXPECT_DOUBLE_EQ(ModelRadius(2, 10, 0, 0), kMaxModelRadiusM);
}

TEST(LocalModelTest, AModelHoldsWhatIsNearAsPrimitivesAndAPatch) {
  const auto scene = Scene();
  const Vector3 c(0, 0, 0.105);  // just above the ball's top
  const LocalModel model = CutLocalModel(*scene, c, 0.02, 3, 1.5);
  EXPECT_EQ(model.version, 3u);
  EXPECT_EQ(model.t_s, 1.5);
  EXPECT_EQ(model.left_out, 0);
  // ball and box; not "far", nor the floor 0.3 m below (unbounded, but its solid is
  // beyond the ball)
  ASSERT_EQ(model.objects.size(), 2u);
  EXPECT_EQ(model.objects[0].name, "ball");
  const auto& patch = std::get<scene::MeshSpec>(model.objects[0].shape);
  EXPECT_GT(patch.triangles.size(), 50u);
  EXPECT_LT(patch.triangles.size(), 2000u);  // a patch, not the 81,920
  for (const Vector3& v : patch.vertices) EXPECT_LE((v - c).norm(), 0.02 + 0.005);
  EXPECT_EQ(model.objects[1].name, "box");
  EXPECT_TRUE(std::holds_alternative<scene::BoxShape>(model.objects[1].shape));
  // the floor is in a model whose ball reaches its face
  const LocalModel low = CutLocalModel(*scene, Vector3(0.5, 0, -0.19), 0.02, 4, 1.5);
  ASSERT_EQ(low.objects.size(), 1u);
  EXPECT_EQ(low.objects[0].name, "floor");
  EXPECT_EQ(model.objects[0].material.stiffness, 3000);
}

TEST(LocalModelTest, AWholeSmallMeshStaysAClosedSolid) {
  scene::SceneBuilder builder;
  builder.Add(Pinned(MakeObject("ball", MeshOf(geometry::MakeIcosphere(4, 0.01)), {0, 0, 0}, MakeMaterial(3000))));
  const LocalModel model = CutLocalModel(*builder.Build(1), Vector3::Zero(), 0.1, 1, 0);
  ASSERT_EQ(model.objects.size(), 1u);
  EXPECT_EQ(std::get<scene::MeshSpec>(model.objects[0].shape).triangles.size(), 320u);
  LocalRenderer device(force::SessionSettings{});
  ASSERT_TRUE(device.Accept(model, 0));
  // inside the solid: the god-object is pushed out (an open patch has no inside)
  device.Reset(Vector3(0, 0, 0.02));
  force::DeviceInput input;
  for (double z = 0.02; z > 0.005; z -= 0.0002) {
    input.p_WD = Vector3(0, 0, z);
    const force::TickOutput out = device.Tick(input, 0.001);
    if (z < 0.0095) {
      EXPECT_GT(out.f_W.z(), 0) << z;
    }
  }
}

// A finger proxy sliding over the dense ball: from the models a renderer cuts about it
// as it goes (a new one every 5 ticks), the device renders what the whole scene gives.
TEST(LocalModelTest, RenderingFromModelsEqualsRenderingFromTheScene) {
  const auto scene = Scene();
  force::SessionSettings settings;
  settings.avatar = {force::AvatarType::kSphere, 0.005, force::ForceMethod::kFingerProxy, false};
  force::RenderSession direct(settings);
  LocalRenderer device(settings);
  const Vector3 start(0, 0, 0.11);
  direct.Reset(start);
  device.Reset(start);
  uint64_t version = 0;
  int contacts = 0;
  for (int k = 0; k < 1500; ++k) {
    const double t = k * 0.001;
    // down into the ball's top, then along it
    const Vector3 p(0.03 * std::max(t - 0.5, 0.0), 0, 0.11 - 0.02 * std::min(t, 0.5));
    if (k % 5 == 0) {
      ASSERT_TRUE(device.Accept(CutLocalModel(*scene, p, ModelRadius(0.5, 0.01, 0.005, 0.005), ++version, t), t));
    }
    ASSERT_TRUE(device.Covers(p));
    force::DeviceInput input;
    input.p_WD = p;
    const force::TickOutput a = direct.Tick(*scene, input, 0.001);
    const force::TickOutput b = device.Tick(input, 0.001);
    ASSERT_LE((a.avatar_W - b.avatar_W).norm(), 1e-12) << k;
    ASSERT_LE((a.f_W - b.f_W).norm(), 1e-9) << k;
    contacts += a.contact;
  }
  EXPECT_GT(contacts, 800);
  EXPECT_EQ(device.blends(), 0);  // the models agreed wherever the avatar was
}

// A kinematic box moves on by its velocity between models; a model that puts it
// elsewhere (its velocity changed) is blended in over kModelBlendS, not jumped to.
TEST(LocalModelTest, KinematicObjectsMoveOnAndACorrectedPoseIsBlended) {
  scene::SceneBuilder builder;
  scene::ObjectSpec box = MakeObject("lift", scene::BoxShape{Vector3(0.05, 0.05, 0.01)}, {0, 0, -0.01}, MakeMaterial(2000));
  box.motion = scene::Motion::kKinematic;
  box.v_WB = Vector3(0, 0, 0.01);  // rising 1 cm/s
  builder.Add(box);
  LocalRenderer device(force::SessionSettings{});
  device.Reset(Vector3(0, 0, 0.001));
  ASSERT_TRUE(device.Accept(CutLocalModel(*builder.Build(1), Vector3::Zero(), 0.2, 1, 0), 0.0));
  force::DeviceInput input;
  input.p_WD = Vector3(0, 0, 0.001);
  force::TickOutput out;
  for (int k = 0; k < 200; ++k) out = device.Tick(input, 0.001);
  // the last tick rendered the top at 1.99 mm (t = 0.199 s): 0.99 mm into the device point
  EXPECT_NEAR(out.f_W.z(), 2000 * 0.00099, 1e-5);
  // the renderer's box stopped at 1.5 mm: the new model disagrees about the surface
  box.X_WB.translation.z() = -0.0085;
  box.v_WB.setZero();
  builder.Update(box);
  ASSERT_TRUE(device.Accept(CutLocalModel(*builder.Build(2), Vector3::Zero(), 0.2, 2, 0.2), 0.2));
  const double before = out.f_W.z();
  std::vector<double> forces;
  for (int k = 0; k < 8; ++k) forces.push_back(device.Tick(input, 0.001).f_W.z());
  EXPECT_EQ(device.blends(), 1);
  EXPECT_NEAR(forces[0], before, 1e-9);  // no jump
  for (int k = 1; k < 8; ++k) EXPECT_LE(forces[k], forces[k - 1] + 1e-12);
  EXPECT_NEAR(forces.back(), 2000 * 0.0005, 1e-5);  // the new model's force, once blended
  // an older model than the one held is refused
  EXPECT_FALSE(device.Accept(CutLocalModel(*builder.Build(2), Vector3::Zero(), 0.2, 1, 0.2), 0.2));
}

// A rising, drifting lift moved off the tick (KinematicMotion, swapped in by Move) renders
// as the tick-moved one does, its ticks and swaps allocating and freeing nothing; a
// renderer moved by its caller does not move the lift itself, and a swap is neither a new
// version nor a blend.
TEST(LocalModelTest, AMotionMovedByTheCallerRendersAsOneMovedByTheTick) {
  constexpr double kDt = 0.001;
  scene::SceneBuilder builder;
  scene::ObjectSpec box = MakeObject("lift", scene::BoxShape{Vector3(0.05, 0.05, 0.01)}, {0, 0, -0.01}, MakeMaterial(2000));
  box.motion = scene::Motion::kKinematic;
  box.v_WB = Vector3(0.002, 0, 0.01);  // rising 1 cm/s, drifting 2 mm/s
  box.w_WB = Vector3(0, 0, 0.1);       // and turning about z
  builder.Add(box);
  const LocalModel model = CutLocalModel(*builder.Build(1), Vector3::Zero(), 0.2, 1, 0);
  const Vector3 p(0, 0, 0.001);
  force::DeviceInput input;
  input.p_WD = p;

  LocalRenderer ticked(force::SessionSettings{});
  ticked.Reset(p);
  ASSERT_TRUE(ticked.Accept(model, 0));
  LocalRenderer moved(force::SessionSettings{}, ModelMotion::kByCaller);
  moved.Reset(p);
  std::unique_ptr<PreparedModel> prepared = LocalRenderer::Prepare(model, 0);
  KinematicMotion motion;
  motion.Follow(*prepared);
  EXPECT_TRUE(motion.moving());
  EXPECT_EQ(motion.version(), 1u);
  ASSERT_TRUE(moved.Adopt(prepared));

  // left alone, a renderer moved by its caller keeps the lift where it was: 1 mm below
  // the device point, no force
  for (int k = 0; k < 20; ++k) EXPECT_EQ(moved.Tick(input, kDt).f_W.norm(), 0) << k;
  EXPECT_EQ(moved.scene_t_s(), 0);
  moved.Reset(p);
  for (int k = 0; k < 20; ++k) ticked.Tick(input, kDt);
  ticked.Reset(p);

  // from 20 ticks on, the lift is moved to each tick's time off the tick
  std::shared_ptr<const scene::SceneSnapshot> scene = motion.SceneAt(20 * kDt);
  ASSERT_TRUE(moved.Move(scene, 20 * kDt));
  long allocations = 0;
  long frees = 0;
  int contacts = 0;
  for (int k = 20; k < 400; ++k) {
    const force::TickOutput a = ticked.Tick(input, kDt);
    const long allocated_before = hapticd::testing::ThreadAllocationCount();
    const long freed_before = hapticd::testing::ThreadFreeCount();
    const force::TickOutput b = moved.Tick(input, kDt);
    allocations += hapticd::testing::ThreadAllocationCount() - allocated_before;
    frees += hapticd::testing::ThreadFreeCount() - freed_before;
    ASSERT_LE((a.f_W - b.f_W).norm(), 1e-9) << k;
    ASSERT_LE((a.avatar_W - b.avatar_W).norm(), 1e-12) << k;
    contacts += b.contact;
    // the next tick's scene, built here as a builder thread would
    const double t = (k + 1) * kDt;
    scene = motion.SceneAt(t);
    const std::shared_ptr<const scene::SceneSnapshot> held = scene;
    const long allocated_at_move = hapticd::testing::ThreadAllocationCount();
    const long freed_at_move = hapticd::testing::ThreadFreeCount();
    ASSERT_TRUE(moved.Move(scene, t));
    allocations += hapticd::testing::ThreadAllocationCount() - allocated_at_move;
    frees += hapticd::testing::ThreadFreeCount() - freed_at_move;
    // the scene it replaced comes back to be freed here
    ASSERT_NE(scene, held);
    ASSERT_EQ(scene->version(), 1u);
    EXPECT_EQ(moved.scene_t_s(), t);
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(frees, 0);
  EXPECT_GT(contacts, 250);  // the lift reaches the point at 0.1 s
  // moved to 0.4 s, the top is at 4 mm: 3 mm into the device point (to the 1 um skin)
  EXPECT_NEAR(moved.Tick(input, kDt).f_W.z(), 2000 * 0.003, 2000 * 1e-6);
  EXPECT_EQ(moved.model_version(), 1u);
  EXPECT_EQ(moved.blends(), 0);

  // a scene of another version than the model held stays with the caller
  builder.Update(box);
  std::shared_ptr<const scene::SceneSnapshot> other = builder.Build(2);
  const std::shared_ptr<const scene::SceneSnapshot> other_held = other;
  EXPECT_FALSE(moved.Move(other, 1.0));
  EXPECT_EQ(other, other_held);
  std::shared_ptr<const scene::SceneSnapshot> none;
  EXPECT_FALSE(moved.Move(none, 1.0));
  EXPECT_FALSE(LocalRenderer(force::SessionSettings{}, ModelMotion::kByCaller).Move(scene, 1.0));
}

}  // namespace
}  // namespace hapticd::remote
