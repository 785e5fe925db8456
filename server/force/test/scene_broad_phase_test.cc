// The scene queries visit only the objects near them (the snapshot's broad phase, kept
// up to date by every edit): on random scenes of 1,000 objects (primitives, small
// meshes on both backends, a plane, kinematic objects moving between snapshots, objects
// updated and removed) they answer exactly as a loop over every object does.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "server/force/scene_queries.h"
#include "server/force/shape_queries.h"
#include "server/force/test/test_scenes.h"
#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace hapticd::force {
namespace {

using testing::MakeMaterial;
using testing::MakeObject;
using testing::MeshOf;

// The oracles: the loops over every object that the broad phase replaced.
SceneContact BruteDeepestContact(const scene::SceneSnapshot& scene, const Vector3& c_W, double r, double max_gap) {
  SceneContact deepest;
  const double reach = r + max_gap;
  for (int i = 0; i < scene.num_objects(); ++i) {
    const scene::SceneObject& object = scene.object(i);
    const Vector3 outside = (object.bounds_W.min - c_W).cwiseMax(c_W - object.bounds_W.max).cwiseMax(0.0);
    if (outside.squaredNorm() > reach * reach) continue;
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), reach);
    if (!probe.found) continue;
    const double depth = r - probe.signed_distance;
    if (depth < -max_gap || (deepest.object >= 0 && depth <= deepest.depth)) continue;
    deepest.object = i;
    deepest.depth = depth;
    deepest.point_W = object.X_WB.ToWorld(probe.point_B);
    deepest.normal_W = object.X_WB.DirectionToWorld(probe.normal_B);
  }
  return deepest;
}

SceneSweep BruteSweep(const scene::SceneSnapshot& scene, const Vector3& a_W, const Vector3& b_W, double r) {
  SceneSweep first;
  const geometry::Aabb swept{a_W.cwiseMin(b_W) - Vector3::Constant(r), a_W.cwiseMax(b_W) + Vector3::Constant(r)};
  for (int i = 0; i < scene.num_objects(); ++i) {
    const scene::SceneObject& object = scene.object(i);
    if (!geometry::AabbsOverlap(swept, object.bounds_W)) continue;
    const ShapeSweep sweep = SweepSphereShape(object.shape, object.X_WB.ToBody(a_W), object.X_WB.ToBody(b_W), r);
    if (!sweep.hit || (first.hit && sweep.t >= first.t)) continue;
    first.hit = true;
    first.object = i;
    first.t = sweep.t;
    first.point_W = object.X_WB.ToWorld(sweep.point_B);
    first.normal_W = object.X_WB.DirectionToWorld(sweep.normal_B);
  }
  return first;
}

class RandomScene {
 public:
  explicit RandomScene(uint64_t seed) : random_(seed) {
    scene::SceneSettings settings;
    settings.budgets.max_objects = 2000;
    builder_ = scene::SceneBuilder(settings);
    scene::ObjectSpec floor = MakeObject("floor", scene::PlaneShape{}, {0, 0, -1}, MakeMaterial(1000));
    builder_.Add(floor);
    for (int i = 0; i < 999; ++i) builder_.Add(RandomObject("object" + std::to_string(i)));
  }

  std::shared_ptr<const scene::SceneSnapshot> Build() { return builder_.Build(++version_); }
  scene::SceneBuilder& builder() { return builder_; }
  Vector3 RandomPoint() { return {coordinate_(random_), coordinate_(random_), coordinate_(random_)}; }
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random_); }
  std::mt19937_64& random() { return random_; }

  scene::ObjectSpec RandomObject(const std::string& name) {
    const double size = Uniform(0.005, 0.05);
    scene::ShapeSpec shape;
    switch (std::uniform_int_distribution<int>(0, 4)(random_)) {
      case 0: shape = scene::SphereShape{size}; break;
      case 1: shape = scene::BoxShape{Vector3(size, 0.7 * size, 0.4 * size)}; break;
      case 2: shape = scene::CapsuleShape{0.5 * size, size}; break;
      case 3: shape = MeshOf(geometry::MakeIcosphere(2, size)); break;
      default: shape = MeshOf(geometry::MakeTorus(size, 0.3 * size, 8, 6)); break;
    }
    scene::ObjectSpec spec = MakeObject(name, shape, RandomPoint(), MakeMaterial(1000));
    spec.X_WB.rotation = Eigen::AngleAxisd(Uniform(0, 3), RandomPoint().normalized()).toRotationMatrix();
    if (std::holds_alternative<scene::MeshSpec>(spec.shape) && Uniform(0, 1) < 0.3) {
      spec.ray_backend = scene::RayBackend::kEmbree;
    }
    if (Uniform(0, 1) < 0.1) {
      spec.motion = scene::Motion::kKinematic;
      spec.v_WB = 0.2 * RandomPoint();
      spec.w_WB = 2.0 * RandomPoint();
    }
    return spec;
  }

 private:
  std::mt19937_64 random_;
  std::uniform_real_distribution<double> coordinate_{-1, 1};
  scene::SceneBuilder builder_;
  uint64_t version_ = 0;
};

void ExpectSameContact(const SceneContact& got, const SceneContact& want, const std::string& what) {
  ASSERT_EQ(got.object, want.object) << what;
  if (want.object < 0) return;
  EXPECT_EQ(got.depth, want.depth) << what;
  EXPECT_EQ(got.point_W, want.point_W) << what;
  EXPECT_EQ(got.normal_W, want.normal_W) << what;
}

void ExpectSameSweep(const SceneSweep& got, const SceneSweep& want, const std::string& what) {
  ASSERT_EQ(got.hit, want.hit) << what;
  if (!want.hit) return;
  EXPECT_EQ(got.object, want.object) << what;
  EXPECT_EQ(got.t, want.t) << what;
  EXPECT_EQ(got.point_W, want.point_W) << what;
  EXPECT_EQ(got.normal_W, want.normal_W) << what;
}

// Queries from random places, most of them near an object, on snapshots between which
// kinematic objects move (by their velocity, and by MoveKinematic), objects are updated
// into other shapes and removed, and new ones added.
TEST(SceneBroadPhase, QueriesEqualALoopOverEveryObject) {
  RandomScene world(41);
  int contacts = 0, hits = 0;
  for (int round = 0; round < 6; ++round) {
    const auto scene = world.Build();
    for (int q = 0; q < 300; ++q) {
      // near a random object's box, or anywhere
      const scene::SceneObject& near = scene->object(1 + q % (scene->num_objects() - 1));
      const Vector3 c = q % 3 == 0 ? world.RandomPoint() : Vector3(near.bounds_W.center() + 0.02 * world.RandomPoint());
      const double r = q % 2 == 0 ? 0.0 : 0.005;
      const std::string what = "round " + std::to_string(round) + " query " + std::to_string(q);
      const SceneContact want = BruteDeepestContact(*scene, c, r, 0.01);
      ExpectSameContact(FindDeepestContact(*scene, c, r, 0.01), want, what);
      contacts += want.object >= 0;
      const Vector3 b = c + 0.05 * world.RandomPoint();
      const SceneSweep sweep = BruteSweep(*scene, c, b, r);
      ExpectSameSweep(SweepSphereScene(*scene, c, b, r), sweep, what + " (sweep)");
      hits += sweep.hit;
    }
    // edits between snapshots
    scene::SceneBuilder& builder = world.builder();
    builder.AdvanceKinematic(0.05 * (round + 1));
    for (int k = 0; k < 20; ++k) {
      const int i = std::uniform_int_distribution<int>(1, builder.num_objects() - 1)(world.random());
      const scene::SceneObject& object = scene->object(std::min(i, scene->num_objects() - 1));
      const std::string name = object.name;
      if (builder.Build(1)->FindObject(name) < 0) continue;
      switch (k % 4) {
        case 0: builder.Remove(name); break;
        case 1: builder.Update(world.RandomObject(name)); break;
        case 2: builder.Add(world.RandomObject("added" + std::to_string(round) + "_" + std::to_string(k))); break;
        default:
          if (object.motion == scene::Motion::kKinematic) {
            scene::Pose pose;
            pose.translation = world.RandomPoint();
            builder.MoveKinematic(name, pose, 0.1 * world.RandomPoint(), Vector3::Zero());
          }
      }
    }
  }
  std::printf("contacts found: %d of 1800 queries; sweep hits: %d of 1800\n", contacts, hits);
  EXPECT_GT(contacts, 300);
  EXPECT_GT(hits, 300);
}

// The kinematic objects a proxy may rest on are listed by the snapshot, ascending.
TEST(SceneBroadPhase, KinematicObjectsAreListedInOrder) {
  RandomScene world(42);
  const auto scene = world.Build();
  std::vector<int> expected;
  for (int i = 0; i < scene->num_objects(); ++i) {
    if (scene->object(i).motion == scene::Motion::kKinematic) expected.push_back(i);
  }
  EXPECT_EQ(std::vector<int>(scene->kinematic_objects().begin(), scene->kinematic_objects().end()), expected);
  EXPECT_GT(expected.size(), 50u);
}

}  // namespace
}  // namespace hapticd::force
