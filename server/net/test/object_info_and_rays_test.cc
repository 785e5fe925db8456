// What the control channel reports of meshes and rays: an object's info carries its
// mesh's closure, rewinding and warnings (WriteObjectInfo), and a batch of rays obeys
// the single ray cast's rule (query/shape_queries.h) on every representation, the Embree
// packets included.

#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server/query/scene_queries.h"
#include "server/geometry/mesh_generators.h"
#include "server/net/proto_convert.h"
#include "server/net/ray_batch.h"
#include "server/scene/scene_builder.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

scene::ObjectSpec MeshObject(std::string name, std::vector<Vector3> vertices,
                             std::vector<std::array<int, 3>> triangles, scene::Representation pin) {
  scene::ObjectSpec spec;
  spec.name = std::move(name);
  scene::MeshSpec mesh;
  mesh.vertices = std::move(vertices);
  mesh.triangles = std::move(triangles);
  mesh.pin = pin;
  spec.shape = mesh;
  return spec;
}

TEST(ObjectInfo, SaysWhetherAMeshIsClosedRewoundOrFarFromItsPin) {
  scene::SceneSettings settings;
  settings.tolerance = 1e-4;
  scene::SceneBuilder builder(settings);
  const std::vector<Vector3> tetra = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  builder.Add(MeshObject("inside_out", tetra, {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}},
                         scene::Representation::kMesh));
  builder.Add(MeshObject("sheet", {{0, 0, 3}, {1, 0, 3}, {1, 1, 3}}, {{0, 1, 2}}, scene::Representation::kAuto));
  const geometry::TriangleMesh ball = geometry::MakeIcosphere(4, 0.5);
  scene::ObjectSpec boxed = MeshObject("boxed", ball.vertices(), ball.triangles(), scene::Representation::kBox);
  boxed.X_WB.translation = {5, 0, 0};
  builder.Add(boxed);
  scene::ObjectSpec sphere;
  sphere.name = "sphere";
  sphere.shape = scene::SphereShape{0.1};
  sphere.X_WB.translation = {-5, 0, 0};
  builder.Add(sphere);
  const auto snapshot = builder.Build(1);

  v1::ObjectInfo info;
  WriteObjectInfo(snapshot->object(0), &info);
  EXPECT_TRUE(info.closed());
  EXPECT_EQ(info.topology(), "closed");
  EXPECT_EQ(info.rewound_triangles(), 4u);
  ASSERT_EQ(info.warnings_size(), 1);
  EXPECT_EQ(info.warnings(0), "rewound 4 of 4 triangles so that the mesh's normals point out of its solid");

  info.Clear();
  WriteObjectInfo(snapshot->object(1), &info);
  EXPECT_FALSE(info.closed());
  EXPECT_EQ(info.topology(), "open");
  EXPECT_EQ(info.representation(), "mesh");
  ASSERT_EQ(info.warnings_size(), 1);
  EXPECT_NE(info.warnings(0).find("a surface with no inside"), std::string::npos);

  // a pin beyond the tolerance: kept, with both numbers named
  info.Clear();
  WriteObjectInfo(snapshot->object(2), &info);
  EXPECT_EQ(info.representation(), "box");
  EXPECT_GT(info.representation_error(), 1e-4);
  ASSERT_EQ(info.warnings_size(), 1);
  EXPECT_NE(info.warnings(0).find("the pinned box is within "), std::string::npos) << info.warnings(0);
  EXPECT_NE(info.warnings(0).find("beyond the scene's tolerance 0.0001 m"), std::string::npos) << info.warnings(0);

  // a primitive: none of it
  info.Clear();
  WriteObjectInfo(snapshot->object(3), &info);
  EXPECT_FALSE(info.closed());
  EXPECT_EQ(info.topology(), "");
  EXPECT_EQ(info.warnings_size(), 0);
}

// A pin with no finite bound (a flat sheet as a sphere) is refused naming the pin.
TEST(ObjectInfo, APinWithNoBoundIsRefused) {
  scene::SceneSettings settings;
  settings.tolerance = 1e-4;
  scene::SceneBuilder builder(settings);
  try {
    builder.Add(MeshObject("sheet", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}},
                           scene::Representation::kSphere));
    ADD_FAILURE() << "accepted";
  } catch (const scene::SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("objects[sheet].shape.pin: cannot represent the mesh as a sphere: its "
                                         "distance from the mesh has no finite bound"),
              std::string::npos)
        << e.what();
  }
}

// The same box as a primitive, a hull and a mesh on each backend: a batch of random
// rays from inside, outside and on the surface gets the answers of single ray casts
// (on Embree too, where a packet's hit at distance 0 is decided by the single ray's
// rule: a ray leaving the surface passes).
TEST(RayCastBatch, EveryRepresentationFollowsTheSingleRaysRule) {
  const Vector3 half(0.5, 0.75, 1);
  const geometry::TriangleMesh box_mesh = geometry::MakeBoxMesh(half, 2);
  std::vector<std::shared_ptr<const scene::SceneSnapshot>> scenes;
  for (int kind = 0; kind < 4; ++kind) {
    scene::SceneBuilder builder;
    scene::ObjectSpec spec = MeshObject("box", box_mesh.vertices(), box_mesh.triangles(),
                                        kind == 1 ? scene::Representation::kConvex : scene::Representation::kMesh);
    if (kind == 0) spec.shape = scene::BoxShape{half};
    if (kind == 3) spec.ray_backend = scene::RayBackend::kEmbree;
    builder.Add(spec);
    scenes.push_back(builder.Build(1));
  }
  std::mt19937_64 random(77);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::normal_distribution<double> gaussian;
  v1::RayCastBatch batch;
  batch.set_max_distance(2);
  std::vector<Vector3> origins, directions;
  for (int i = 0; i < 600; ++i) {
    Vector3 a = half.cwiseProduct(Vector3(unit(random), unit(random), unit(random)));
    if (i % 3 == 1) a *= 3;               // mostly outside
    if (i % 3 == 2) a[i % 3] = half[i % 3];  // on the surface
    const Vector3 d = Vector3(gaussian(random), gaussian(random), gaussian(random)).normalized();
    for (int k = 0; k < 3; ++k) batch.add_origins(a[k]), batch.add_directions(d[k]);
    origins.push_back(a);
    directions.push_back(d);
  }
  const v1::RayHits expected = CastRayBatch(*scenes[0], batch);
  int hits = 0, leaving_the_surface = 0;
  for (size_t s = 0; s < scenes.size(); ++s) {
    const v1::RayHits got = CastRayBatch(*scenes[s], batch);
    for (int i = 0; i < static_cast<int>(origins.size()); ++i) {
      const bool on_surface = i % 3 == 2;
      const bool outwards = directions[i][i % 3] > 0;
      if (s == 3 && on_surface && outwards) ++leaving_the_surface;
      ASSERT_EQ(got.hit(i), expected.hit(i)) << "scene " << s << " ray " << i << " from " << origins[i].transpose()
                                             << " along " << directions[i].transpose() << " at "
                                             << got.distance(i);
      // and each batch answer is the single ray's
      const query::SceneSweep single =
          query::SweepSphereScene(*scenes[s], origins[i], origins[i] + 2 * directions[i], 0);
      ASSERT_EQ(single.hit, got.hit(i)) << "scene " << s << " ray " << i;
      if (!got.hit(i)) continue;
      hits += s == 0;
      EXPECT_NEAR(got.distance(i), expected.distance(i), 1e-9) << "scene " << s << " ray " << i;
      EXPECT_NEAR(got.distance(i), 2 * single.t, 1e-9) << "scene " << s << " ray " << i;
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(got.normals(3 * i + k), expected.normals(3 * i + k), 1e-9) << "scene " << s << " ray " << i;
        EXPECT_NEAR(got.points(3 * i + k), expected.points(3 * i + k), 1e-9) << "scene " << s << " ray " << i;
      }
    }
  }
  EXPECT_GT(hits, 200);
  EXPECT_GT(leaving_the_surface, 50);
}

}  // namespace
}  // namespace hapticd::net
