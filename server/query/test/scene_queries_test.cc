// The scene queries visit only the objects near them (the snapshot's broad phase, kept
// up to date by every edit): on random scenes of 1,000 objects (primitives, small
// meshes on both backends, a plane, kinematic objects moving between snapshots, objects
// updated and removed) they answer exactly as a loop over every object does.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "server/query/scene_queries.h"
#include "server/query/shape_queries.h"
#include "server/scene/test/test_scenes.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/mesh_generators.h"
#include "server/scene/scene_builder.h"

namespace hapticd::query {
namespace {

using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

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

std::vector<SceneContact> BruteObjectContacts(const scene::SceneSnapshot& scene, const Vector3& c_W, double r) {
  std::vector<SceneContact> contacts;
  for (int i = 0; i < scene.num_objects(); ++i) {
    const scene::SceneObject& object = scene.object(i);
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), r);
    if (!probe.found || probe.signed_distance > r) continue;
    contacts.push_back({i, r - probe.signed_distance, object.X_WB.ToWorld(probe.point_B),
                        object.X_WB.DirectionToWorld(probe.normal_B), probe.triangle});
  }
  return contacts;
}

int BruteKinematicCarrier(const scene::SceneSnapshot& scene, const Vector3& c_W, double reach) {
  for (int i = 0; i < scene.num_objects(); ++i) {
    const scene::SceneObject& object = scene.object(i);
    if (object.motion != scene::Motion::kKinematic) continue;
    const ShapeProbe probe = ProbeShape(object.shape, object.X_WB.ToBody(c_W), reach);
    if (probe.found && probe.signed_distance <= reach) return i;
  }
  return -1;
}

// Every object's pieces of surface within radius, by a different route: a solid's probe,
// and each triangle of a mesh through the closest point on that triangle alone.
std::vector<SceneFeature> BruteFeatures(const scene::SceneSnapshot& scene, const Vector3& c_W, double radius) {
  std::vector<SceneFeature> features;
  for (int i = 0; i < scene.num_objects(); ++i) {
    const scene::SceneObject& object = scene.object(i);
    const Vector3 p_B = object.X_WB.ToBody(c_W);
    if (const auto* mesh = std::get_if<scene::MeshShape>(&object.shape)) {
      const geometry::TriangleMesh& triangles = mesh->bvh->mesh();
      for (int t = 0; t < triangles.num_triangles(); ++t) {
        const geometry::ClosestPointOnTriangle on = geometry::FindClosestPointOnTriangle(p_B, triangles.triangle(t));
        const double distance = (p_B - on.point).norm();
        if (distance <= radius) features.push_back({i, t, distance, object.X_WB.ToWorld(on.point), Vector3::Zero()});
      }
      continue;
    }
    const ShapeProbe probe = ProbeShape(object.shape, p_B, radius);
    if (!probe.found || probe.signed_distance > radius) continue;
    features.push_back({i, -1, probe.signed_distance, object.X_WB.ToWorld(probe.point_B),
                        object.X_WB.DirectionToWorld(probe.normal_B)});
  }
  return features;
}

class RandomScene {
 public:
  // backend: every mesh on it; kCount: a mix (most native, some Embree)
  explicit RandomScene(uint64_t seed, scene::RayBackend backend = scene::RayBackend::kCount)
      : random_(seed), backend_(backend) {
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
    const bool embree = Uniform(0, 1) < 0.3;
    if (std::holds_alternative<scene::MeshSpec>(spec.shape)) {
      spec.ray_backend = backend_ != scene::RayBackend::kCount ? backend_
                         : embree                              ? scene::RayBackend::kEmbree
                                                               : scene::RayBackend::kNative;
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
  scene::RayBackend backend_;
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

void ExpectSameFeatures(const FeatureSet& got, std::vector<SceneFeature> want, const std::string& what) {
  ASSERT_FALSE(got.truncated()) << what;
  ASSERT_EQ(got.features().size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k) {
    const SceneFeature& g = got.features()[k];
    EXPECT_EQ(g.object, want[k].object) << what;
    EXPECT_EQ(g.triangle, want[k].triangle) << what;
    EXPECT_NEAR(g.distance, want[k].distance, 1e-12) << what;
    EXPECT_LT((g.point_W - want[k].point_W).norm(), 1e-12) << what;
    if (want[k].triangle < 0) {
      EXPECT_EQ(g.normal_W, want[k].normal_W) << what;
    }
    EXPECT_NEAR(g.normal_W.norm(), 1, 1e-12) << what;
  }
}

// The scene's other questions against their loops over every object.
void ExpectOtherQueriesEqualLoops(const scene::SceneSnapshot& scene, const Vector3& c, const Vector3& b, double r,
                                  const std::string& what) {
  const std::vector<SceneContact> want = BruteObjectContacts(scene, c, r);
  const std::vector<SceneContact> got = FindObjectContacts(scene, c, r);
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k) ExpectSameContact(got[k], want[k], what + " (contacts)");
  EXPECT_EQ(FindKinematicContact(scene, c, r).object, BruteKinematicCarrier(scene, c, r)) << what;
  FeatureSet features(4096);
  FindFeaturesWithin(scene, c, r, features);
  ExpectSameFeatures(features, BruteFeatures(scene, c, r), what + " (features)");
  // a batch of segments from c equals each segment's own point sweep
  std::array<Vector3, 3> a_W{c, c, b};
  std::array<Vector3, 3> b_W{b, Vector3(2 * b - c), c};
  std::array<SceneSweep, 3> batch;
  CastSegments(scene, a_W, b_W, batch);
  for (int k = 0; k < 3; ++k) {
    ExpectSameSweep(batch[k], SweepSphereScene(scene, a_W[k], b_W[k], 0), what + " (batch " + std::to_string(k) + ")");
  }
}

// Queries from random places, most of them near an object, on snapshots between which
// kinematic objects move (by their velocity, and by MoveKinematic), objects are updated
// into other shapes and removed, and new ones added.
TEST(SceneQueries, EqualALoopOverEveryObject) {
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
      if (q % 10 == 0) ExpectOtherQueriesEqualLoops(*scene, c, b, 0.01 + r, what);
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

// The batch queries answer as the single ones (the loops over every object): closest
// points found nearest first, at reaches from a few millimetres to the whole scene,
// inside solids and far from all; contacts laid end to end with their counts.
TEST(SceneQueries, BatchesAnswerAsSingleQueries) {
  RandomScene world(45);
  const auto scene = world.Build();
  std::vector<Vector3> points;
  for (int q = 0; q < 600; ++q) {
    const scene::SceneObject& near = scene->object(1 + q % (scene->num_objects() - 1));
    points.push_back(q % 3 == 0 ? world.RandomPoint() : Vector3(near.bounds_W.center() + 0.02 * world.RandomPoint()));
  }
  points.push_back(Vector3(NAN, 0, 0));
  int inside = 0;
  for (const double reach : {0.005, 0.3, 3.0}) {
    std::vector<SceneContact> nearest(points.size());
    FindClosestPoints(*scene, points, reach, nearest);
    for (std::size_t q = 0; q < points.size(); ++q) {
      const std::string what = "reach " + std::to_string(reach) + " point " + std::to_string(q);
      ExpectSameContact(nearest[q], BruteDeepestContact(*scene, points[q], 0, reach), what);
      inside += nearest[q].object >= 0 && nearest[q].depth > 0;
    }
    EXPECT_EQ(nearest.back().object, -1);
  }
  EXPECT_GT(inside, 30);

  std::vector<double> radii;
  for (std::size_t q = 0; q < points.size(); ++q) radii.push_back(world.Uniform(0, 0.05));
  std::vector<SceneContact> laid;
  std::vector<int> counts(points.size(), -1);
  ASSERT_TRUE(FindObjectContactsBatch(*scene, points, radii, 1'000'000, laid, counts));
  std::size_t k = 0;
  for (std::size_t q = 0; q < points.size(); ++q) {
    const std::vector<SceneContact> want = BruteObjectContacts(*scene, points[q], radii[q]);
    ASSERT_EQ(counts[q], static_cast<int>(want.size())) << q;
    for (const SceneContact& contact : want) ExpectSameContact(laid[k++], contact, "centre " + std::to_string(q));
  }
  EXPECT_EQ(k, laid.size());
  EXPECT_GT(laid.size(), 300u);
  // one radius for all; and a bound below what they find stops the batch
  laid.clear();
  const std::array<double, 1> one{0.03};
  ASSERT_TRUE(FindObjectContactsBatch(*scene, points, one, 1'000'000, laid, counts));
  for (std::size_t q = 0; q < points.size(); ++q) {
    ASSERT_EQ(counts[q], static_cast<int>(BruteObjectContacts(*scene, points[q], 0.03).size())) << q;
  }
  const std::size_t all = laid.size();
  laid.clear();
  EXPECT_FALSE(FindObjectContactsBatch(*scene, points, one, all - 1, laid, counts));
  laid.clear();
  EXPECT_TRUE(FindObjectContactsBatch(*scene, points, one, all, laid, counts));
}

// The same scene with every mesh on the native BVH and on Embree answers alike.
TEST(SceneQueries, NativeAndEmbreeAgree) {
  RandomScene native(43, scene::RayBackend::kNative), embree(43, scene::RayBackend::kEmbree);
  const auto a = native.Build(), b = embree.Build();
  ASSERT_EQ(a->num_objects(), b->num_objects());
  FeatureSet features_a(4096), features_b(4096);
  int hits = 0, features = 0;
  for (int q = 0; q < 400; ++q) {
    const scene::SceneObject& near = a->object(1 + q % (a->num_objects() - 1));
    const Vector3 c = near.bounds_W.center() + 0.02 * native.RandomPoint();
    const Vector3 end = c + 0.05 * native.RandomPoint();
    const double r = q % 2 == 0 ? 0.0 : 0.005;
    const std::string what = "query " + std::to_string(q);
    ExpectSameContact(FindDeepestContact(*b, c, r, 0.01), FindDeepestContact(*a, c, r, 0.01), what);
    // where two triangles are hit at exactly the same t either may be reported: the
    // object and t agree, and a point's crossing (a sphere may touch two triangles
    // at once at different points, most often when it starts touching both)
    const SceneSweep sweep_a = SweepSphereScene(*a, c, end, r), sweep_b = SweepSphereScene(*b, c, end, r);
    ASSERT_EQ(sweep_a.hit, sweep_b.hit) << what;
    if (sweep_a.hit) {
      EXPECT_EQ(sweep_a.object, sweep_b.object) << what;
      EXPECT_EQ(sweep_a.t, sweep_b.t) << what;
      if (r == 0) {
        EXPECT_EQ(sweep_a.point_W, sweep_b.point_W) << what;
      }
    }
    hits += sweep_a.hit;
    FindFeaturesWithin(*a, c, 0.01, features_a);
    FindFeaturesWithin(*b, c, 0.01, features_b);
    ASSERT_EQ(features_a.features().size(), features_b.features().size()) << what;
    for (std::size_t k = 0; k < features_a.features().size(); ++k) {
      EXPECT_EQ(features_a.features()[k].triangle, features_b.features()[k].triangle) << what;
      EXPECT_EQ(features_a.features()[k].distance, features_b.features()[k].distance) << what;
    }
    features += static_cast<int>(features_a.features().size());
  }
  EXPECT_GT(hits, 50);
  EXPECT_GT(features, 1000);
}

// A full set keeps the nearest features; the one it drops is no nearer than any kept.
TEST(SceneQueries, AFullFeatureSetKeepsTheNearest) {
  RandomScene world(44);
  const auto scene = world.Build();
  int truncated = 0;
  for (int q = 0; q < 100; ++q) {
    const scene::SceneObject& near = scene->object(1 + q % (scene->num_objects() - 1));
    const Vector3 c = near.bounds_W.center() + 0.01 * world.RandomPoint();
    std::vector<SceneFeature> all = BruteFeatures(*scene, c, 0.02);
    FeatureSet kept(5);
    FindFeaturesWithin(*scene, c, 0.02, kept);
    ASSERT_EQ(kept.features().size(), std::min<std::size_t>(5, all.size()));
    EXPECT_EQ(kept.truncated(), all.size() > 5);
    if (all.size() <= 5) continue;
    ++truncated;
    std::sort(all.begin(), all.end(), [](const SceneFeature& x, const SceneFeature& y) { return x.distance < y.distance; });
    double farthest_kept = -1e300;
    for (const SceneFeature& f : kept.features()) farthest_kept = std::max(farthest_kept, f.distance);
    EXPECT_LE(farthest_kept, all[5].distance + 1e-12);
    EXPECT_NEAR(farthest_kept, all[4].distance, 1e-12);
  }
  EXPECT_GT(truncated, 20);
  // bad input finds nothing
  FeatureSet none(8);
  FindFeaturesWithin(*scene, Vector3(NAN, 0, 0), 0.1, none);
  EXPECT_TRUE(none.features().empty());
  FindFeaturesWithin(*scene, Vector3::Zero(), -1, none);
  EXPECT_TRUE(none.features().empty());
  FindFeaturesWithin(*scene, Vector3::Zero(), INFINITY, none);
  EXPECT_TRUE(none.features().empty());
}

// The kinematic objects a proxy may rest on are listed by the snapshot, ascending.
TEST(SceneQueries, KinematicObjectsAreListedInOrder) {
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
}  // namespace hapticd::query
