// A neighbourhood answers every query as the whole scene does (the direct path is the
// oracle): on random scenes of small objects and dense meshes (on both ray backends),
// for queries from inside, across and beyond the gathered ball, from spheres resting on
// meshes and sliding over them, with buffers too small to hold what is near.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "server/geometry/capsule_triangle.h"
#include "server/geometry/mesh_generators.h"
#include "server/query/neighbourhood.h"
#include "server/scene/scene_builder.h"
#include "server/scene/test/test_scenes.h"

namespace hapticd::query {
namespace {

using scene::testing::MakeMaterial;
using scene::testing::MakeObject;
using scene::testing::MeshOf;

// 200 objects in a 20 cm cube over a plane: spheres, boxes, capsules, icospheres of
// 1,280 triangles (about 3 mm across a triangle) and tori; a tenth kinematic.
std::shared_ptr<const scene::SceneSnapshot> RandomScene(std::mt19937_64& random, scene::RayBackend backend) {
  std::uniform_real_distribution<double> coordinate(-0.1, 0.1), size(0.01, 0.04), unit(0, 1);
  scene::SceneSettings settings;
  settings.budgets.max_objects = 1000;
  scene::SceneBuilder builder(settings);
  builder.Add(MakeObject("floor", scene::PlaneShape{}, {0, 0, -0.12}, MakeMaterial(1000)));
  for (int i = 0; i < 200; ++i) {
    const double s = size(random);
    scene::ShapeSpec shape;
    switch (i % 5) {
      case 0: shape = scene::SphereShape{s}; break;
      case 1: shape = scene::BoxShape{Vector3(s, 0.7 * s, 0.4 * s)}; break;
      case 2: shape = scene::CapsuleShape{0.5 * s, s}; break;
      case 3: shape = MeshOf(geometry::MakeIcosphere(8, 2 * s)); break;
      default: shape = MeshOf(geometry::MakeTorus(2 * s, 0.6 * s, 24, 12)); break;
    }
    scene::ObjectSpec spec =
        MakeObject(std::string("o").append(std::to_string(i)), shape,
                   {coordinate(random), coordinate(random), coordinate(random)}, MakeMaterial(1000));
    spec.X_WB.rotation =
        Eigen::AngleAxisd(3 * unit(random), Vector3(unit(random), unit(random), 0.5).normalized()).toRotationMatrix();
    if (std::holds_alternative<scene::MeshSpec>(spec.shape)) {
      spec.shape = std::get<scene::MeshSpec>(spec.shape);
      std::get<scene::MeshSpec>(spec.shape).pin = scene::Representation::kMesh;
      spec.ray_backend = backend;
    }
    if (i % 10 == 7) {
      spec.motion = scene::Motion::kKinematic;
      spec.v_WB = Vector3(0.1, 0, 0.05);
    }
    builder.Add(spec);
  }
  return builder.Build(1);
}

Vector3 RandomDirection(std::mt19937_64& random) {
  std::normal_distribution<double> normal;
  return Vector3(normal(random), normal(random), normal(random)).normalized();
}

void ExpectSameContact(const SceneContact& got, const SceneContact& want, const std::string& what) {
  ASSERT_EQ(got.object, want.object) << what;
  if (want.object < 0) return;
  EXPECT_EQ(got.depth, want.depth) << what;
  EXPECT_EQ(got.point_W, want.point_W) << what;
  EXPECT_EQ(got.normal_W, want.normal_W) << what;
  EXPECT_EQ(got.triangle, want.triangle) << what;
}

// The same first contact: the same object at the same t; of several triangles of a mesh
// touched at once (a sphere starting inside it touches many at t = 0), the neighbourhood
// may name another than the mesh's traversal, whose t then differs by rounding at most
// (the mesh sweep rescales it from its shortened sweep).
void ExpectSameSweep(const SceneSweep& got, const SceneSweep& want, const Vector3& a, const Vector3& b, double r,
                     const scene::SceneSnapshot& scene, int* ties, const std::string& what) {
  ASSERT_EQ(got.hit, want.hit) << what;
  if (!want.hit) return;
  ASSERT_EQ(got.object, want.object) << what;
  if (got.point_W == want.point_W && got.normal_W == want.normal_W) {
    EXPECT_EQ(got.t, want.t) << what;
    return;
  }
  ++*ties;
  ASSERT_TRUE(std::holds_alternative<scene::MeshShape>(scene.object(got.object).shape)) << what;
  EXPECT_NEAR(got.t, want.t, 1e-12) << what;
  // both touch the sphere where it stops
  const Vector3 centre = a + got.t * (b - a);
  EXPECT_LE((got.point_W - centre).norm(), r + 1e-9) << what;
  EXPECT_LE((want.point_W - centre).norm(), r + 1e-9) << what;
  EXPECT_NEAR(got.normal_W.norm(), 1, 1e-12) << what;
}

// Every query of near, from around its gathered region, against the scene's.
// Returns how many sweeps named another of several triangles touched at once.
int ExpectSameAnswers(const Neighbourhood& near, std::mt19937_64& random, double r, const std::string& what) {
  const scene::SceneSnapshot& scene = near.scene();
  int ties = 0;
  std::uniform_real_distribution<double> unit(0, 1);
  for (int k = 0; k < 20; ++k) {
    // a point inside the region mostly, sometimes beyond it
    const geometry::Capsule& region = near.region_W();
    const Vector3 along = region.p0 + unit(random) * (region.p1 - region.p0);
    const Vector3 a = along + 1.3 * region.radius * unit(random) * RandomDirection(random);
    const Vector3 b = a + 0.6 * near.region_W().radius * unit(random) * RandomDirection(random);
    const std::string where = what + " a " + std::to_string(a.x()) + "," + std::to_string(a.y()) + "," +
                              std::to_string(a.z()) + " k " + std::to_string(k);
    ExpectSameSweep(SweepSphereScene(near, a, b, r), SweepSphereScene(scene, a, b, r), a, b, r, scene, &ties,
                    where + " sweep");
    ExpectSameContact(FindDeepestContact(near, a, r, 0.2 * near.region_W().radius),
                      FindDeepestContact(scene, a, r, 0.2 * near.region_W().radius), where + " deepest");
    ExpectSameContact(FindKinematicContact(near, a, r + 1e-6), FindKinematicContact(scene, a, r + 1e-6),
                      where + " carrier");
    // resting on the nearest surface (a skin off it) and pressing into it or sliding
    const SceneContact on = FindDeepestContact(scene, a, r, near.region_W().radius);
    if (on.object < 0) continue;
    const Vector3 rest = on.point_W + (r + 1e-9) * on.normal_W;
    const Vector3 slide = RandomDirection(random).cross(on.normal_W) * 0.3 * near.region_W().radius;
    for (const Vector3& to : {Vector3(rest + slide), Vector3(rest + slide - 0.1 * r * on.normal_W),
                              Vector3(rest - 0.3 * near.region_W().radius * on.normal_W)}) {
      ExpectSameSweep(SweepSphereScene(near, rest, to, r), SweepSphereScene(scene, rest, to, r), rest, to, r, scene,
                      &ties, where + " resting");
    }
  }
  return ties;
}

class NeighbourhoodAnswers : public ::testing::TestWithParam<scene::RayBackend> {};

TEST_P(NeighbourhoodAnswers, AreTheScenesFromEveryWhereAroundTheRegion) {
  std::mt19937_64 random(12);
  const auto scene = RandomScene(random, GetParam());
  Neighbourhood near(kDefaultNeighbourObjects, kDefaultNeighbourTriangles);
  std::uniform_real_distribution<double> coordinate(-0.12, 0.12), unit(0, 1);
  int with_triangles = 0, ties = 0;
  for (int trial = 0; trial < 150; ++trial) {
    const double r = trial % 3 == 0 ? 0 : 0.002 + 0.008 * unit(random);
    const Vector3 c(coordinate(random), coordinate(random), coordinate(random));
    // a ball, or a sausage along a segment up to 3 cm long
    const Vector3 end = trial % 2 ? Vector3(c + 0.03 * unit(random) * RandomDirection(random)) : c;
    near.Gather(*scene, c, end, r + 0.02 * unit(random), r > 0);
    ASSERT_TRUE(near.gathered());
    with_triangles += near.num_triangles() > 0;
    ties += ExpectSameAnswers(near, random, r, "trial " + std::to_string(trial) + " r " + std::to_string(r));
  }
  // ties are the exception (sweeps that start inside a mesh)
  EXPECT_LT(ties, 150) << ties;  // of some 12,000 sweeps
  // many balls met a mesh, and both ways of answering were taken often
  EXPECT_GT(with_triangles, 30);
  EXPECT_GT(near.local_answers(), 2000);
  EXPECT_GT(near.scene_answers(), 2000);
}

TEST_P(NeighbourhoodAnswers, AreTheScenesWhenTheBuffersAreTooSmall) {
  std::mt19937_64 random(13);
  const auto scene = RandomScene(random, GetParam());
  // a few triangles: the meshes are asked whole; one object: nothing is gathered
  Neighbourhood few_triangles(kDefaultNeighbourObjects, 40);
  Neighbourhood one_object(1, kDefaultNeighbourTriangles);
  std::uniform_real_distribution<double> coordinate(-0.12, 0.12);
  int ungathered = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Vector3 c(coordinate(random), coordinate(random), coordinate(random));
    few_triangles.Gather(*scene, c, 0.03);
    ExpectSameAnswers(few_triangles, random, 0.005, "few triangles, trial " + std::to_string(trial));
    one_object.Gather(*scene, c, 0.03);
    ungathered += !one_object.gathered();
    if (!one_object.gathered()) ExpectSameAnswers(one_object, random, 0.005, "one object, trial " + std::to_string(trial));
  }
  EXPECT_GT(ungathered, 10);
}

INSTANTIATE_TEST_SUITE_P(Backends, NeighbourhoodAnswers,
                         ::testing::Values(scene::RayBackend::kNative, scene::RayBackend::kEmbree));

TEST(Neighbourhood, GathersNothingFromBadInputAndAsksTheScene) {
  std::mt19937_64 random(14);
  const auto scene = RandomScene(random, scene::RayBackend::kNative);
  Neighbourhood near(kDefaultNeighbourObjects, kDefaultNeighbourTriangles);
  for (const double radius : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    near.Gather(*scene, Vector3::Zero(), radius);
    EXPECT_FALSE(near.gathered());
  }
  near.Gather(*scene, Vector3(std::nan(""), 0, 0), 0.01);
  EXPECT_FALSE(near.gathered());
  const Vector3 a(0, 0, 0.2), b(0, 0, -0.2);
  int ties = 0;
  ExpectSameSweep(SweepSphereScene(near, a, b, 0.003), SweepSphereScene(*scene, a, b, 0.003), a, b, 0.003, *scene,
                  &ties, "after a bad gather");
  EXPECT_EQ(ties, 0);
  // a neighbourhood of no capacity never gathers
  Neighbourhood none(0, 0);
  none.Gather(*scene, Vector3::Zero(), 0.01);
  EXPECT_FALSE(none.gathered());
}

// The original indices of the triangles GatherMeshTriangles keeps for region, sorted,
// after checking that it keeps each once and every triangle of the mesh within the
// radius of the segment (the exact distance, geometry::CalcCapsuleTriangleContact).
std::vector<int> ExpectGathersEveryTriangleWithin(const geometry::MeshBvh& bvh, const geometry::Capsule& region,
                                                  std::vector<geometry::PreparedTriangle>& out, int trial) {
  const int found = geometry::GatherMeshTriangles(bvh, region, out);
  EXPECT_LE(found, static_cast<int>(out.size())) << trial;
  std::vector<int> got;
  for (int k = 0; k < std::min(found, static_cast<int>(out.size())); ++k) got.push_back(out[k].index);
  std::sort(got.begin(), got.end());
  EXPECT_EQ(std::adjacent_find(got.begin(), got.end()), got.end()) << trial << ": a triangle twice";
  const geometry::TriangleMesh& mesh = bvh.mesh();
  for (int i = 0; i < mesh.num_triangles(); ++i) {
    const double distance = geometry::CalcCapsuleTriangleContact({region.p0, region.p1, 0}, mesh.triangle(i)).distance;
    if (distance > region.radius) continue;
    EXPECT_TRUE(std::binary_search(got.begin(), got.end(), i))
        << trial << ": triangle " << i << " at " << distance << " of " << region.radius << " left out";
  }
  return got;
}

// The gathered triangles hold every triangle within the radius of the segment and none
// beyond the ball about it that the BVH is walked with.
TEST(GatherMeshTriangles, HoldsEveryTriangleWithinTheRegionAndFewMore) {
  const auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(20, 0.05));
  const geometry::MeshBvh bvh(mesh);
  std::vector<geometry::PreparedTriangle> out(4000);
  std::mt19937_64 random(15);
  std::uniform_real_distribution<double> unit(0, 1);
  int kept_beyond = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const Vector3 a = 0.05 * RandomDirection(random) * (0.8 + 0.4 * unit(random));
    // balls, and segments up to 1 cm long
    const Vector3 b = trial % 2 ? Vector3(a + 0.01 * unit(random) * RandomDirection(random)) : a;
    const geometry::Capsule region{a, b, 0.001 * (1 + trial % 7)};
    const std::vector<int> got = ExpectGathersEveryTriangleWithin(bvh, region, out, trial);
    for (const int i : got) {
      const geometry::Triangle tri = mesh->triangle(i);
      const double distance = geometry::CalcCapsuleTriangleContact({a, b, 0}, tri).distance;
      if (distance <= region.radius) continue;
      // kept beyond: its box met the ball about the segment, so it lies within that
      // ball's radius and the box's diagonal (at most 2 sqrt(3) bounding radii)
      ++kept_beyond;
      const double rho = geometry::PrepareTriangle(tri, i).bounding_radius;
      EXPECT_LE(distance, region.radius + 0.5 * (b - a).norm() + 2 * std::sqrt(3.0) * rho + 1e-12)
          << trial << ": triangle " << i;
    }
    // too small a buffer: says so
    const int found = static_cast<int>(got.size());
    if (found > 2) {
      EXPECT_EQ(geometry::GatherMeshTriangles(bvh, region, std::span(out).first(found - 1)), found);
    }
  }
  // the bound is not exact: some kept triangles lie a little beyond
  EXPECT_GT(kept_beyond, 0);
}

// Long thin sausages over a fine mesh: the distance bound's case where the point of the
// segment nearest a triangle's centre lies inside the segment decides most triangles
// near the edge of the region, and none within it may be left out.
TEST(GatherMeshTriangles, AlongLongSegmentsHoldsEveryTriangleWithinTheRegion) {
  // 32,000 triangles of about 1.4 mm
  const auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(40, 0.05));
  const geometry::MeshBvh bvh(mesh);
  std::vector<geometry::PreparedTriangle> out(4000);
  std::mt19937_64 random(16);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int trial = 0; trial < 40; ++trial) {
    // from just over the surface, 1 to 2 cm across it, 0.2 to 1 mm wide
    const Vector3 a = (0.05 + 0.001 * unit(random)) * RandomDirection(random);
    const Vector3 b = a + (0.01 + 0.01 * unit(random)) * RandomDirection(random).cross(a.normalized());
    ExpectGathersEveryTriangleWithin(bvh, {a, b, 0.0002 + 0.0008 * unit(random)}, out, trial);
    if (HasFailure()) return;
  }
}

// The walk tests the BVH's boxes in float. Here each triangle has a corner that is its
// box's greatest in every axis, and a ball reaches from beyond it in every axis exactly
// to it, so the triangle's boxes lie at the very radius; every triangle within the
// radius must still be kept.
//  - Near the origin, from 1e-3 to 1e2 times the scene's size away, on float
//    coordinates: the boxes and the centre are exact, and only the slack for the
//    rounding of a float distance (about 1e-7 of itself) keeps them.
//  - At 1e6, where a float ulp is 0.06, from 1e-3 to 1 away: only the ball's box
//    rounded outwards keeps them.
TEST(GatherMeshTriangles, FloatWalkKeepsTrianglesAtExactlyTheRadius) {
  std::mt19937_64 random(1205);
  std::uniform_real_distribution<double> unit(0, 1);
  const auto to_float = [](const Vector3& p) { return Vector3(p.cast<float>().cast<double>()); };
  const auto random_vector = [&] { return Vector3(unit(random), unit(random), unit(random)); };
  struct Case {
    Vector3 offset;
    double size;       // of each triangle
    double min_log10;  // of the ball's centre's distance
    double max_log10;
    bool centre_on_float;
  };
  int at_radius = 0;
  for (const Case& c : {Case{Vector3::Zero(), 0.05, -3, 2, true}, Case{Vector3(1e6, -1e6, 1e6), 2, -3, 0, false}}) {
    std::vector<Vector3> vertices;
    std::vector<geometry::TriangleMesh::TriangleIndices> triangles;
    for (int t = 0; t < 300; ++t) {
      const Vector3 corner = to_float(c.offset + 2 * random_vector() - Vector3::Ones());
      const auto below = [&] { return to_float(corner - c.size * (Vector3::Constant(0.1) + random_vector())); };
      const int first = static_cast<int>(vertices.size());
      vertices.insert(vertices.end(), {corner, below(), below()});
      triangles.push_back({first, first + 1, first + 2});
    }
    const auto mesh = std::make_shared<const geometry::TriangleMesh>(vertices, triangles);
    const geometry::MeshBvh bvh(mesh);
    std::vector<geometry::PreparedTriangle> out(mesh->num_triangles());
    for (int trial = 0; trial < 600; ++trial) {
      const Vector3 v = vertices[3 * (trial % 300)];
      const Vector3 away = v + std::pow(10.0, c.min_log10 + (c.max_log10 - c.min_log10) * unit(random)) *
                                   RandomDirection(random).cwiseAbs();
      const Vector3 centre = c.centre_on_float ? to_float(away) : away;
      const geometry::Capsule region{centre, centre, (centre - v).norm()};
      const int found = geometry::GatherMeshTriangles(bvh, region, out);
      ASSERT_LE(found, static_cast<int>(out.size())) << trial;
      std::vector<int> got;
      for (int k = 0; k < found; ++k) got.push_back(out[k].index);
      std::sort(got.begin(), got.end());
      for (int i = 0; i < mesh->num_triangles(); ++i) {
        const double distance =
            geometry::CalcCapsuleTriangleContact({centre, centre, 0}, mesh->triangle(i)).distance;
        if (distance > region.radius) continue;
        at_radius += distance > region.radius * (1 - 1e-9);
        EXPECT_TRUE(std::binary_search(got.begin(), got.end(), i))
            << trial << ": triangle " << i << " at " << distance << " of " << region.radius << " left out";
      }
      if (HasFailure()) return;
    }
  }
  EXPECT_GT(at_radius, 600);
}

// The sausage along a slide on a dense surface holds fewer triangles than the ball about
// it (the region before it, as render_tick.md measures at 1.3M triangles).
TEST(GatherMeshTriangles, AlongASlideHoldsFewerThanTheBallAboutIt) {
  // 288,000 triangles of about 0.5 mm
  const auto mesh = std::make_shared<const geometry::TriangleMesh>(geometry::MakeIcosphere(120, 0.05));
  const geometry::MeshBvh bvh(mesh);
  std::vector<geometry::PreparedTriangle> out(4000);
  // a 5 mm sphere resting on the sphere, sliding 0.2 mm, gathered 40 micrometres wide
  const double r = 0.005;
  const Vector3 a(0.05 + r, 0, 0), b = Vector3(0.05 + r, 0.0002, 0);
  const int sausage = geometry::GatherMeshTriangles(bvh, {a, b, r + 4e-5}, out);
  const int ball = geometry::GatherMeshTriangles(bvh, {0.5 * (a + b), 0.5 * (a + b), r + 4e-5 + 1e-4}, out);
  EXPECT_GT(sausage, 0);
  EXPECT_LT(3 * sausage, 2 * ball) << sausage << " against " << ball;
}

}  // namespace
}  // namespace hapticd::query
