// Per-shape avatar queries: exact probes, and sweeps against independent oracles (the
// analytic ray-sphere root; the mesh sweep over the same surface triangulated).

#include "server/query/shape_queries.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/sphere_convex_sweep.h"
#include "server/geometry/sphere_sweep.h"

namespace hapticd::query {
namespace {

using geometry::MeshBvh;
using geometry::TriangleMesh;

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(ProbeShape, ExactDistancesAndNormals) {
  const ShapeProbe sphere = ProbeShape(scene::SphereShape{0.5}, Vector3(0, 0.75, 0), kInf);
  EXPECT_EQ(sphere.signed_distance, 0.25);
  EXPECT_EQ(sphere.normal_B, Vector3::UnitY());
  EXPECT_EQ(sphere.point_B, Vector3(0, 0.5, 0));

  const scene::BoxShape box{Vector3(1, 2, 4)};
  const ShapeProbe outside = ProbeShape(box, Vector3(4, 6, 0), kInf);
  EXPECT_EQ(outside.signed_distance, 5.0);
  EXPECT_EQ(outside.point_B, Vector3(1, 2, 0));
  const ShapeProbe inside = ProbeShape(box, Vector3(0.5, -1.75, 0), kInf);
  EXPECT_EQ(inside.signed_distance, -0.25);
  EXPECT_EQ(inside.normal_B, -Vector3::UnitY());
  EXPECT_EQ(inside.point_B, Vector3(0.5, -2, 0));

  const ShapeProbe capsule = ProbeShape(scene::CapsuleShape{0.25, 1}, Vector3(0, 0, 1.5), kInf);
  EXPECT_EQ(capsule.signed_distance, 0.25);
  EXPECT_EQ(capsule.normal_B, Vector3::UnitZ());
  const ShapeProbe side = ProbeShape(scene::CapsuleShape{0.25, 1}, Vector3(0.125, 0, 0.5), kInf);
  EXPECT_EQ(side.signed_distance, -0.125);
  EXPECT_EQ(side.normal_B, Vector3::UnitX());

  const ShapeProbe plane = ProbeShape(scene::PlaneShape{}, Vector3(3, 4, -0.5), kInf);
  EXPECT_EQ(plane.signed_distance, -0.5);
  EXPECT_EQ(plane.point_B, Vector3(3, 4, 0));

  // beyond max_distance: not found
  EXPECT_FALSE(ProbeShape(scene::SphereShape{0.5}, Vector3(0, 2, 0), 1.0).found);
}

std::shared_ptr<const geometry::ConvexHull> Octahedron() {
  std::vector<Vector3> points;
  for (int k = 0; k < 3; ++k) points.push_back(Vector3::Unit(k)), points.push_back(-Vector3::Unit(k));
  return std::make_shared<const geometry::ConvexHull>(geometry::BuildConvexHull(points));
}

TEST(ProbeShape, ConvexHullInsideAndOutside) {
  const scene::ConvexShape octahedron{Octahedron()};
  const double face = 1 / std::sqrt(3.0);
  const ShapeProbe out = ProbeShape(octahedron, Vector3(1, 1, 1), kInf);
  EXPECT_NEAR(out.signed_distance, std::sqrt(3.0) - face, 1e-12);
  EXPECT_NEAR((out.normal_B - Vector3(1, 1, 1).normalized()).norm(), 0, 1e-9);
  const ShapeProbe in = ProbeShape(octahedron, Vector3(0.1, 0.1, 0.1), kInf);
  EXPECT_NEAR(in.signed_distance, 0.3 / std::sqrt(3.0) - face, 1e-12);
  EXPECT_NEAR((in.normal_B - Vector3(1, 1, 1).normalized()).norm(), 0, 1e-12);
}

TEST(ProbeShape, ClosedMeshSignAndDeepInside) {
  const auto mesh = std::make_shared<const TriangleMesh>(geometry::MakeIcosphere(8, 1.0));
  const scene::MeshShape ball{std::make_shared<const MeshBvh>(mesh)};
  EXPECT_LT(ProbeShape(ball, Vector3(0, 0, 0.9), 0.5).signed_distance, 0);
  EXPECT_GT(ProbeShape(ball, Vector3(0, 0, 1.1), 0.5).signed_distance, 0);
  // the centre is 1 m from the surface, beyond max_distance, and still found inside
  const ShapeProbe centre = ProbeShape(ball, Vector3(0.01, 0, 0), 0.1);
  EXPECT_TRUE(centre.found);
  EXPECT_LT(centre.signed_distance, -0.9);
}

// An open mesh is a surface: from either side the distance is the unsigned distance
// (an independent brute force over its triangles), never inside, with the normal from
// the surface towards the point.
TEST(ProbeShape, AnOpenMeshIsASurfaceWithNoInside) {
  const TriangleMesh sphere = geometry::MakeIcosphere(4, 1.0);
  std::vector<TriangleMesh::TriangleIndices> upper;
  for (int t = 0; t < sphere.num_triangles(); ++t) {
    const geometry::Triangle tri = sphere.triangle(t);
    if (tri.v0.z() + tri.v1.z() + tri.v2.z() > 0) upper.push_back(sphere.triangles()[t]);
  }
  const auto bowl = std::make_shared<const TriangleMesh>(sphere.vertices(), upper);
  ASSERT_FALSE(bowl->is_closed());
  const scene::MeshShape shape{std::make_shared<const MeshBvh>(bowl)};
  std::mt19937_64 random(8);
  std::uniform_real_distribution<double> coordinate(-1.5, 1.5);
  for (int i = 0; i < 500; ++i) {
    const Vector3 p(coordinate(random), coordinate(random), coordinate(random));
    double nearest = kInf;
    for (int t = 0; t < bowl->num_triangles(); ++t) {
      nearest = std::min(nearest, std::sqrt(geometry::FindClosestPointOnTriangle(p, bowl->triangle(t)).distance_squared));
    }
    const ShapeProbe probe = ProbeShape(shape, p, kInf);
    ASSERT_TRUE(probe.found) << i;
    EXPECT_NEAR(probe.signed_distance, nearest, 1e-12) << i;
    EXPECT_NEAR((probe.normal_B - (p - probe.point_B).normalized()).norm(), 0, 1e-9) << i;
  }
  // inside the bowl, just under its top: 0.1 m from the surface, not inside it
  EXPECT_NEAR(ProbeShape(shape, Vector3(0, 0, 0.89), kInf).signed_distance, 0.1, 0.01);
}

// A closed mesh given inside out has its inside back (it was the outside before
// validation rewound it): 2 cm inside the tetrahedron is -2 cm, on every backend.
TEST(ProbeShape, AnInsideOutTetrahedronHasItsInside) {
  const std::vector<Vector3> vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const auto tetra = std::make_shared<const TriangleMesh>(
      vertices, std::vector<TriangleMesh::TriangleIndices>{{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}});
  ASSERT_EQ(tetra->num_rewound_triangles(), 4);
  const scene::MeshShape shape{std::make_shared<const MeshBvh>(tetra)};
  const ShapeProbe inside = ProbeShape(shape, Vector3(0.02, 0.3, 0.3), kInf);
  ASSERT_TRUE(inside.found);
  EXPECT_NEAR(inside.signed_distance, -0.02, 1e-15);
  EXPECT_EQ(inside.normal_B, Vector3(-1, 0, 0));
  EXPECT_NEAR(ProbeShape(shape, Vector3(-0.02, 0.3, 0.3), kInf).signed_distance, 0.02, 1e-15);
}

TEST(ProbeShape, NonFiniteInputFindsNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ProbeShape(scene::BoxShape{Vector3::Ones()}, Vector3(nan, 0, 0), kInf).found);
  EXPECT_FALSE(SweepSphereShape(scene::SphereShape{1}, Vector3(nan, 0, 0), Vector3(3, 0, 0), 0.1).hit);
  EXPECT_FALSE(SweepSphereShape(scene::SphereShape{1}, Vector3(3, 0, 0), Vector3(-3, 0, 0), nan).hit);
  // an infinite radius too, whatever the representation
  EXPECT_FALSE(SweepSphereShape(scene::SphereShape{1}, Vector3(3, 0, 0), Vector3(-3, 0, 0), kInf).hit);
  EXPECT_FALSE(SweepSphereShape(scene::BoxShape{Vector3::Ones()}, Vector3(3, 0, 0), Vector3(-3, 0, 0), kInf).hit);
  const scene::MeshShape mesh{std::make_shared<const MeshBvh>(std::make_shared<const TriangleMesh>(
      geometry::MakeBoxMesh(Vector3::Ones(), 1)))};
  EXPECT_FALSE(SweepSphereShape(mesh, Vector3(3, 0, 0), Vector3(-3, 0, 0), kInf).hit);
}

// The first root of |a + t d| = R + r, the analytic answer for a sphere.
double RaySphereRoot(const Vector3& a, const Vector3& d, double radius) {
  const double qa = d.squaredNorm(), qb = 2 * a.dot(d), qc = a.squaredNorm() - radius * radius;
  const double disc = qb * qb - 4 * qa * qc;
  if (disc < 0) return kInf;
  const double t = (-qb - std::sqrt(disc)) / (2 * qa);
  return t >= 0 && t <= 1 ? t : kInf;
}

TEST(SweepSphereShape, SphereMatchesTheAnalyticRoot) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> coordinate(-2, 2), radius(0, 0.3);
  int hits = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vector3 a(coordinate(random), coordinate(random), coordinate(random));
    const Vector3 b(coordinate(random), coordinate(random), coordinate(random));
    const double r = radius(random);
    if (a.norm() < 1 + r + 1e-6) continue;  // start outside
    const double expected = RaySphereRoot(a, b - a, 1 + r);
    const ShapeSweep sweep = SweepSphereShape(scene::SphereShape{1}, a, b, r);
    ASSERT_EQ(sweep.hit, expected <= 1) << i;
    if (!sweep.hit) continue;
    ++hits;
    EXPECT_NEAR(sweep.t, expected, 1e-8);
    const Vector3 centre = a + sweep.t * (b - a);
    EXPECT_NEAR((sweep.normal_B - centre.normalized()).norm(), 0, 1e-8);
  }
  EXPECT_GT(hits, 500);
}

// The sphere's sweep asks its probe at a only where a starts deep inside; the answer is
// that of the rule written out from the public pieces (probe at a; from deep inside,
// the kernel's sweep back from b; else the kernel's sweep), bit for bit, over random
// sweeps starting outside, on the shell, just inside and deep inside.
TEST(SweepSphereShape, SphereEqualsTheProbeAndKernelRule) {
  const double tolerance = geometry::kConvexSweepTolerance;
  const double radius = 0.7;
  const scene::Shape ball = scene::SphereShape{radius};
  const geometry::Sphere kernel_ball{Vector3::Zero(), radius};
  auto rule = [&](const Vector3& a, const Vector3& b, double r) {
    ShapeSweep out;
    if (r == 0 && ProbeShape(ball, a, kInf).signed_distance < -tolerance) {
      const ShapeProbe end = ProbeShape(ball, b, kInf);
      if (!end.found || end.signed_distance < -tolerance) return out;
      const geometry::ConvexSweepHit exit = geometry::SweepSphereSphere(kernel_ball, b, a, 0);
      if (!exit.hit) return out;
      return ShapeSweep{.hit = true, .t = 1 - exit.t, .point_B = exit.point, .normal_B = -exit.normal};
    }
    const geometry::ConvexSweepHit hit = geometry::SweepSphereSphere(kernel_ball, a, b, r);
    if (hit.hit) out = ShapeSweep{.hit = true, .t = hit.t, .point_B = hit.point, .normal_B = hit.normal};
    return out;
  };
  std::mt19937_64 random(41);
  std::uniform_real_distribution<double> coordinate(-2, 2), unit(0, 1);
  std::normal_distribution<double> normal;
  int inside = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vector3 dir = Vector3(normal(random), normal(random), normal(random)).normalized();
    // the start's distance from the centre: anywhere, or within a few tolerances of R
    const double shells[] = {2 * unit(random), radius - 3 * tolerance * unit(random),
                             radius - tolerance, radius + tolerance * (2 * unit(random) - 1)};
    const Vector3 a = shells[i % 4] * dir;
    const Vector3 b = i % 3 == 0 ? Vector3(-a + 0.01 * dir) : Vector3(coordinate(random), coordinate(random), coordinate(random));
    const double r = i % 5 == 0 ? 0.1 * unit(random) : 0;
    if (a == b) continue;
    if (r == 0 && ProbeShape(ball, a, kInf).signed_distance < -tolerance) ++inside;
    const ShapeSweep got = SweepSphereShape(ball, a, b, r);
    const ShapeSweep want = rule(a, b, r);
    ASSERT_EQ(got.hit, want.hit) << i;
    if (!want.hit) continue;
    ASSERT_EQ(got.t, want.t) << i;
    ASSERT_EQ(got.point_B, want.point_B) << i;
    ASSERT_EQ(got.normal_B, want.normal_B) << i;
  }
  EXPECT_GT(inside, 3000);
}

// A sphere that starts touching the primitive (within the sweep tolerance) is stopped
// at once only by motion into it; a point from inside leaves it where the segment
// crosses the surface (the ray rule), with the normal turned back inwards.
TEST(SweepSphereShape, SphereStartingInContactOnlyMotionIntoItHits) {
  const scene::Shape ball = scene::SphereShape{1};
  const Vector3 on_top(0, 0, 1.25);  // r = 0.25: touching
  EXPECT_FALSE(SweepSphereShape(ball, on_top, on_top + Vector3(0.5, 0, 0), 0.25).hit);
  EXPECT_FALSE(SweepSphereShape(ball, on_top, on_top + Vector3(0, 0, 0.5), 0.25).hit);
  const ShapeSweep into = SweepSphereShape(ball, on_top, on_top + Vector3(0.5, 0, -0.5), 0.25);
  ASSERT_TRUE(into.hit);
  EXPECT_EQ(into.t, 0);
  EXPECT_EQ(into.point_B, Vector3(0, 0, 1));
  EXPECT_EQ(into.normal_B, Vector3::UnitZ());
  const Vector3 inside(0, 0.5, 0);
  const ShapeSweep out = SweepSphereShape(ball, inside, Vector3(0, 3, 0), 0);
  ASSERT_TRUE(out.hit);
  EXPECT_NEAR(out.t, 0.2, 1e-10);  // leaves at y = 1 (within the 1e-10 m touching tolerance)
  EXPECT_NEAR((out.point_B - Vector3(0, 1, 0)).norm(), 0, 1e-9);
  EXPECT_NEAR((out.normal_B - Vector3(0, -1, 0)).norm(), 0, 1e-9);
  // ending inside: never leaves
  EXPECT_FALSE(SweepSphereShape(ball, inside, Vector3(0, 0.25, 0), 0).hit);
  EXPECT_FALSE(SweepSphereShape(ball, Vector3::Zero(), Vector3(0, 0, -0.5), 0).hit);
  // ending exactly on the surface: leaves at t = 1
  const ShapeSweep to_surface = SweepSphereShape(ball, Vector3::Zero(), Vector3(0, 0, 1), 0);
  ASSERT_TRUE(to_surface.hit);
  EXPECT_NEAR(to_surface.t, 1, 1e-9);
  // from the surface: into the ball at once, out of it never
  const ShapeSweep from_surface = SweepSphereShape(ball, Vector3(0, 0, 1), Vector3(0, 0, -3), 0);
  ASSERT_TRUE(from_surface.hit);
  EXPECT_EQ(from_surface.t, 0);
  EXPECT_FALSE(SweepSphereShape(ball, Vector3(0, 0, 1), Vector3(0, 0, 3), 0).hit);
  // passing by 1e-6 beyond reach, and ending 1e-6 short of it: misses
  EXPECT_FALSE(SweepSphereShape(ball, Vector3(-2, 1.25 + 1e-6, 0), Vector3(2, 1.25 + 1e-6, 0), 0.25).hit);
  EXPECT_FALSE(SweepSphereShape(ball, Vector3(0, 3, 0), Vector3(0, 1.25 + 1e-6, 0), 0.25).hit);
  const ShapeSweep ends_on = SweepSphereShape(ball, Vector3(0, 3, 0), Vector3(0, 1.25, 0), 0.25);
  ASSERT_TRUE(ends_on.hit);
  EXPECT_NEAR(ends_on.t, 1, 1e-9);
}

// Box and hull against the mesh sweep over the same surface (an independent
// implementation): the same hit or miss, and each one's contact distance equal to r at
// the other's time.
void CompareWithMeshSweep(const scene::Shape& shape, const TriangleMesh& surface, uint64_t seed) {
  const MeshBvh bvh(std::make_shared<const TriangleMesh>(surface));
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> coordinate(-2, 2), radius(0, 0.3);
  int hits = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vector3 a(coordinate(random), coordinate(random), coordinate(random));
    const Vector3 b(coordinate(random), coordinate(random), coordinate(random));
    const double r = radius(random);
    if (ProbeShape(shape, a, kInf).signed_distance < r + 1e-6) continue;  // start apart
    const ShapeSweep sweep = SweepSphereShape(shape, a, b, r);
    const geometry::SphereSweepHit oracle = geometry::SweepSphereMesh(bvh, a, b, r);
    if (sweep.hit != oracle.hit) {
      // only a graze within the tolerances may disagree
      const double t = sweep.hit ? sweep.t : oracle.t;
      EXPECT_NEAR(ProbeShape(shape, a + t * (b - a), kInf).signed_distance, r, 1e-7) << i;
      continue;
    }
    if (!sweep.hit) continue;
    ++hits;
    EXPECT_NEAR(sweep.t, oracle.t, 1e-6 / (b - a).norm() + 1e-9) << i;
    EXPECT_NEAR(ProbeShape(shape, a + sweep.t * (b - a), kInf).signed_distance, r, 1e-8) << i;
  }
  EXPECT_GT(hits, 300);
}

TEST(SweepSphereShape, BoxAgreesWithItsTriangulatedSurface) {
  CompareWithMeshSweep(scene::BoxShape{Vector3(0.5, 0.75, 1)},
                       geometry::MakeBoxMesh(Vector3(0.5, 0.75, 1), 2), 12);
}

TEST(SweepSphereShape, ConvexHullAgreesWithItsTriangulatedSurface) {
  const auto hull = Octahedron();
  std::vector<std::array<int, 3>> faces(hull->faces.begin(), hull->faces.end());
  CompareWithMeshSweep(scene::ConvexShape{hull}, TriangleMesh(hull->vertices, faces), 13);
}

TEST(SweepSphereShape, RestingOnASurfaceOnlyMotionIntoItHits) {
  const scene::BoxShape box{Vector3(1, 1, 1)};
  const Vector3 on_top(0.2, 0.3, 1.1);  // a 0.1 sphere resting on the top face
  EXPECT_FALSE(SweepSphereShape(box, on_top, on_top + Vector3(0.3, 0, 0), 0.1).hit);
  EXPECT_FALSE(SweepSphereShape(box, on_top, on_top + Vector3(0, 0, 0.3), 0.1).hit);
  const ShapeSweep into = SweepSphereShape(box, on_top, on_top + Vector3(0.1, 0, -0.3), 0.1);
  EXPECT_TRUE(into.hit);
  EXPECT_EQ(into.t, 0.0);
  EXPECT_EQ(into.normal_B, Vector3::UnitZ());
  // the plane: moving along it never hits, into it at once
  EXPECT_FALSE(SweepSphereShape(scene::PlaneShape{}, Vector3(0, 0, 0), Vector3(1, 0, 0), 0).hit);
  EXPECT_TRUE(SweepSphereShape(scene::PlaneShape{}, Vector3(0, 0, 0.5), Vector3(1, 0, -0.5), 0).hit);
}

TEST(ShadingNormal, InterpolatesVertexNormalsOnMeshesOnly) {
  EXPECT_EQ(CalcShadingNormal(scene::SphereShape{1}, -1, Vector3::UnitX(), Vector3::UnitX()),
            Vector3::UnitX());
  const auto mesh = std::make_shared<const TriangleMesh>(geometry::MakeIcosphere(1, 1.0));
  const scene::MeshShape ball{std::make_shared<const MeshBvh>(mesh)};
  const geometry::Triangle t = mesh->triangle(0);
  const Vector3 face = (t.v1 - t.v0).cross(t.v2 - t.v0).normalized();
  // at a vertex: that vertex's normal (radial on an icosphere)
  EXPECT_NEAR((CalcShadingNormal(ball, 0, t.v1, face) - t.v1.normalized()).norm(), 0, 1e-9);
  // at the centroid of an equilateral facet: the facet normal
  const Vector3 centroid = (t.v0 + t.v1 + t.v2) / 3;
  EXPECT_NEAR((CalcShadingNormal(ball, 0, centroid, face) - face).norm(), 0, 1e-9);
}

}  // namespace
}  // namespace hapticd::query
