// One ray-cast rule for every representation (shape_queries.h): a point swept from a to
// b reports the first surface crossing, from whichever side; from inside a solid that is
// where it leaves, with the normal turned back towards a. The same box as a primitive,
// as its hull, as a mesh on both backends and as the automatic choice gives the same
// answer to random rays starting inside, outside and on the surface.

#include <array>
#include <cmath>
#include <optional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server/query/scene_queries.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::query {
namespace {

using scene::testing::BuildScene;
using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

const Vector3 kHalf(0.5, 0.75, 1);  // dyadic: the faces' coordinates are exact
const Vector3 kCentre(0.25, -0.5, 2);

struct Representation {
  std::string name;
  std::shared_ptr<const scene::SceneSnapshot> scene;
};

// The box, placed at kCentre, in each representation a client can ask for.
std::vector<Representation> MakeBoxes() {
  const geometry::TriangleMesh box_mesh = geometry::MakeBoxMesh(kHalf, 2);
  std::vector<Representation> out;
  auto add = [&](std::string name, scene::ShapeSpec shape, std::optional<scene::RayBackend> backend) {
    scene::ObjectSpec spec = MakeObject("box", std::move(shape), kCentre, MakeMaterial(1000));
    spec.ray_backend = backend;
    out.push_back({std::move(name), BuildScene({spec})});
  };
  add("primitive", scene::BoxShape{kHalf}, std::nullopt);
  scene::MeshSpec hull = MeshOf(box_mesh);
  hull.pin = scene::Representation::kConvex;
  add("hull", hull, std::nullopt);
  add("native mesh", MeshOf(box_mesh), scene::RayBackend::kNative);
  add("embree mesh", MeshOf(box_mesh), scene::RayBackend::kEmbree);
  scene::MeshSpec automatic = MeshOf(box_mesh);
  automatic.pin = scene::Representation::kAuto;
  add("automatic", automatic, std::nullopt);
  return out;
}

TEST(RayCastRule, RepresentationsAreWhatTheyClaim) {
  const std::vector<Representation> boxes = MakeBoxes();
  EXPECT_EQ(scene::TypeOf(boxes[0].scene->object(0).shape), scene::ShapeType::kBox);
  EXPECT_EQ(scene::TypeOf(boxes[1].scene->object(0).shape), scene::ShapeType::kConvex);
  const auto& native = std::get<scene::MeshShape>(boxes[2].scene->object(0).shape);
  const auto& embree = std::get<scene::MeshShape>(boxes[3].scene->object(0).shape);
  EXPECT_EQ(native.embree, nullptr);
  EXPECT_NE(embree.embree, nullptr);
}

// A ray from the centre leaves through the face it points at, with the inward normal.
TEST(RayCastRule, FromInsideTheExitIsReported) {
  for (const Representation& box : MakeBoxes()) {
    const SceneSweep up = SweepSphereScene(*box.scene, kCentre, kCentre + Vector3(0, 0, 3), 0);
    ASSERT_TRUE(up.hit) << box.name;
    EXPECT_NEAR(up.t, 1.0 / 3, 1e-12) << box.name;
    EXPECT_NEAR((up.point_W - (kCentre + Vector3(0, 0, 1))).norm(), 0, 1e-9) << box.name;
    EXPECT_NEAR((up.normal_W - Vector3(0, 0, -1)).norm(), 0, 1e-12) << box.name;
    // ending inside: no crossing at all
    EXPECT_FALSE(SweepSphereScene(*box.scene, kCentre, kCentre + Vector3(0.1, 0.1, 0.1), 0).hit) << box.name;
  }
}

// The start: inside (strictly), outside, or exactly on a face.
enum class Start { kInside, kOutside, kOnSurface, kCount };

TEST(RayCastRule, EveryRepresentationAnswersRandomRaysAlike) {
  const std::vector<Representation> boxes = MakeBoxes();
  std::mt19937_64 random(2024);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::normal_distribution<double> gaussian;
  std::uniform_int_distribution<int> face(0, 5);
  std::array<int, 3> hits{}, misses{};
  for (int i = 0; i < 3000; ++i) {
    const Start start = static_cast<Start>(i % static_cast<int>(Start::kCount));
    Vector3 a_B;
    if (start == Start::kInside) {
      a_B = 0.98 * kHalf.cwiseProduct(Vector3(unit(random), unit(random), unit(random)));
    } else if (start == Start::kOutside) {
      do {
        a_B = 2.5 * Vector3(unit(random), unit(random), unit(random));
      } while ((a_B.cwiseAbs() - kHalf).maxCoeff() < 0.01);
    } else {
      a_B = kHalf.cwiseProduct(Vector3(unit(random), unit(random), unit(random)));
      const int f = face(random);
      a_B[f / 2] = f % 2 ? kHalf[f / 2] : -kHalf[f / 2];
    }
    const Vector3 direction = Vector3(gaussian(random), gaussian(random), gaussian(random)).normalized();
    const Vector3 a_W = kCentre + a_B;
    const double length = 0.2 + 2.8 * std::abs(unit(random));
    const Vector3 b_W = a_W + length * direction;
    const SceneSweep expected = SweepSphereScene(*boxes[0].scene, a_W, b_W, 0);
    (expected.hit ? hits : misses)[static_cast<int>(start)]++;
    for (size_t k = 1; k < boxes.size(); ++k) {
      const SceneSweep got = SweepSphereScene(*boxes[k].scene, a_W, b_W, 0);
      ASSERT_EQ(got.hit, expected.hit) << boxes[k].name << " ray " << i;
      if (!got.hit) continue;
      // within the sweeps' 1e-10 m touching tolerance
      EXPECT_NEAR(length * got.t, length * expected.t, 1e-9) << boxes[k].name << " ray " << i;
      EXPECT_NEAR((got.point_W - expected.point_W).norm(), 0, 1e-9) << boxes[k].name << " ray " << i;
      EXPECT_NEAR((got.normal_W - expected.normal_W).norm(), 0, 1e-9) << boxes[k].name << " ray " << i;
    }
    // and the answer is the crossing: from inside the exit (normal against the motion's
    // outward side), from the surface t = 0 exactly when the ray goes in
    if (start == Start::kInside) {
      EXPECT_EQ(expected.hit, ((a_B + length * direction).cwiseAbs() - kHalf).maxCoeff() >= 0) << i;
      if (expected.hit) {
        EXPECT_GT(expected.normal_W.dot(-direction), 0) << i;
      }
    }
    if (start == Start::kOnSurface && expected.hit) {
      EXPECT_EQ(expected.t, 0) << i;
    }
  }
  // every kind of start both hits and misses
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(hits[k], 30) << k;
    EXPECT_GT(misses[k], 30) << k;
  }
}

}  // namespace
}  // namespace hapticd::query
