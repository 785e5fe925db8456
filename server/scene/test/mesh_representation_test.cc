#include "server/scene/mesh_representation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/convex_hull.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/test/random_geometry.h"
#include "server/scene/value_text.h"

namespace hapticd::scene {
namespace {

using geometry::MeshBvh;
using geometry::Triangle;
using geometry::TriangleMesh;
using Indices = TriangleMesh::TriangleIndices;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = std::numbers::pi;

std::shared_ptr<const TriangleMesh> Share(TriangleMesh mesh) {
  return std::make_shared<const TriangleMesh>(std::move(mesh));
}

// The mesh with every vertex moved by X.
TriangleMesh Transformed(const TriangleMesh& mesh, const Pose& X) {
  std::vector<Vector3> vertices;
  for (const Vector3& v : mesh.vertices()) vertices.push_back(X.ToWorld(v));
  return TriangleMesh(vertices, mesh.triangles());
}

// A closed, outward capsule mesh around the z axis: `rings` latitude rings per
// hemisphere, `segments` around, poles at z = +-(half_length + radius).
TriangleMesh MakeCapsuleMesh(double radius, double half_length, int rings, int segments) {
  std::vector<Vector3> vertices = {{0, 0, half_length + radius}};
  auto add_ring = [&](double z, double rho) {
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * kPi * j / segments;
      vertices.push_back({rho * std::cos(phi), rho * std::sin(phi), z});
    }
  };
  for (int k = 1; k <= rings; ++k) {
    const double theta = 0.5 * kPi * k / rings;
    add_ring(half_length + radius * std::cos(theta), radius * std::sin(theta));
  }
  for (int k = rings; k >= 1; --k) {
    const double theta = 0.5 * kPi * k / rings;
    add_ring(-half_length - radius * std::cos(theta), radius * std::sin(theta));
  }
  const int south = static_cast<int>(vertices.size());
  vertices.push_back({0, 0, -half_length - radius});
  const int num_rings = 2 * rings;
  auto ring_vertex = [&](int ring, int j) { return 1 + ring * segments + (j % segments); };
  std::vector<Indices> triangles;
  for (int j = 0; j < segments; ++j) {
    triangles.push_back({0, ring_vertex(0, j), ring_vertex(0, j + 1)});
    for (int ring = 0; ring + 1 < num_rings; ++ring) {
      const int a = ring_vertex(ring, j), b = ring_vertex(ring + 1, j);
      const int c = ring_vertex(ring + 1, j + 1), d = ring_vertex(ring, j + 1);
      triangles.push_back({a, b, c});
      triangles.push_back({a, c, d});
    }
    triangles.push_back({south, ring_vertex(num_rings - 1, j + 1), ring_vertex(num_rings - 1, j)});
  }
  return TriangleMesh(vertices, triangles);
}

// Points covering triangle tri: a barycentric grid with n steps per side.
std::vector<Vector3> SampleTriangle(const Triangle& tri, int n) {
  std::vector<Vector3> points;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
      points.push_back((1 - u - v) * tri.v0 + u * tri.v1 + v * tri.v2);
    }
  }
  return points;
}

// Points on the mesh's surface: a grid on every triangle, plus each triangle's point
// closest to `centre` (where a flat triangle dips deepest into a round shape).
std::vector<Vector3> SampleMesh(const TriangleMesh& mesh, int n, const Vector3& centre) {
  std::vector<Vector3> points;
  for (int t : mesh.nondegenerate_triangles()) {
    const Triangle tri = mesh.triangle(t);
    for (const Vector3& p : SampleTriangle(tri, n)) points.push_back(p);
    points.push_back(geometry::FindClosestPointOnTriangle(centre, tri).point);
  }
  return points;
}

// Distance from p (in S) to the surface of the shape, by a formula per shape (the hull
// by brute force over its faces and their planes).
double DistanceToShapeSurface(const Shape& shape, const Vector3& p) {
  if (const auto* s = std::get_if<SphereShape>(&shape)) return std::abs(p.norm() - s->radius);
  if (const auto* c = std::get_if<CapsuleShape>(&shape)) {
    const double z = std::clamp(p.z(), -c->half_length, c->half_length);
    return std::abs((p - Vector3(0, 0, z)).norm() - c->radius);
  }
  if (const auto* b = std::get_if<BoxShape>(&shape)) {
    const Vector3 q = p.cwiseAbs() - b->half_extents;
    if ((q.array() <= 0).all()) return -q.maxCoeff();
    return q.cwiseMax(0).norm();
  }
  const auto& hull = *std::get<ConvexShape>(shape).hull;
  // inside a convex polytope: the distance to the nearest face plane
  double outside = -kInf;
  for (size_t f = 0; f < hull.faces.size(); ++f) {
    outside = std::max(outside, hull.face_normals[f].dot(p - hull.vertices[hull.faces[f][0]]));
  }
  if (outside <= 0) return -outside;
  double best = kInf;
  for (const auto& f : hull.faces) {
    const Triangle tri{hull.vertices[f[0]], hull.vertices[f[1]], hull.vertices[f[2]]};
    best = std::min(best, std::sqrt(geometry::FindClosestPointOnTriangle(p, tri).distance_squared));
  }
  return best;
}

// Points on the shape's surface, in S, about `spacing` apart (random for round parts).
std::vector<Vector3> SampleShapeSurface(const Shape& shape, double spacing, std::mt19937_64& rng) {
  std::vector<Vector3> points;
  std::normal_distribution<double> normal;
  auto random_direction = [&] { return Vector3(normal(rng), normal(rng), normal(rng)).normalized(); };
  if (const auto* s = std::get_if<SphereShape>(&shape)) {
    const int n = static_cast<int>(4 * kPi * s->radius * s->radius / (spacing * spacing));
    for (int i = 0; i < n; ++i) points.push_back(s->radius * random_direction());
  } else if (const auto* c = std::get_if<CapsuleShape>(&shape)) {
    const int n = static_cast<int>(4 * kPi * c->radius * (c->radius + c->half_length) /
                                   (spacing * spacing));
    std::uniform_real_distribution<double> along(-c->half_length, c->half_length);
    for (int i = 0; i < n; ++i) {
      Vector3 d = random_direction();
      // half the points on the caps, half on the cylinder
      if (i % 2 == 0) {
        points.push_back(c->radius * d + Vector3(0, 0, d.z() > 0 ? c->half_length : -c->half_length));
      } else {
        d.z() = 0;
        points.push_back(c->radius * d.normalized() + Vector3(0, 0, along(rng)));
      }
    }
  } else if (const auto* b = std::get_if<BoxShape>(&shape)) {
    const Vector3 h = b->half_extents;
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, c = (k + 2) % 3;
      const int na = static_cast<int>(2 * h[a] / spacing) + 1, nc = static_cast<int>(2 * h[c] / spacing) + 1;
      for (int side : {-1, 1}) {
        for (int i = 0; i <= na; ++i) {
          for (int j = 0; j <= nc; ++j) {
            Vector3 p;
            p[k] = side * h[k];
            p[a] = -h[a] + 2 * h[a] * i / na;
            p[c] = -h[c] + 2 * h[c] * j / nc;
            points.push_back(p);
          }
        }
      }
    }
  } else {
    const auto& hull = *std::get<ConvexShape>(shape).hull;
    for (const auto& f : hull.faces) {
      const Triangle tri{hull.vertices[f[0]], hull.vertices[f[1]], hull.vertices[f[2]]};
      const double longest = std::max({(tri.v1 - tri.v0).norm(), (tri.v2 - tri.v1).norm(),
                                       (tri.v0 - tri.v2).norm()});
      for (const Vector3& p : SampleTriangle(tri, 1 + static_cast<int>(longest / spacing))) {
        points.push_back(p);
      }
    }
  }
  return points;
}

// The two-sided distance between the mesh and the represented shape, measured by
// sampling both surfaces (a lower bound of the true Hausdorff distance).
struct Measured {
  double mesh_to_shape = 0;
  double shape_to_mesh = 0;
  double both() const { return std::max(mesh_to_shape, shape_to_mesh); }
};

Measured MeasureDeviation(const std::shared_ptr<const TriangleMesh>& mesh,
                          const RepresentedMesh& r, int per_side, double spacing) {
  Measured out;
  const Pose& X_MS = r.choice.X_MS;
  for (const Vector3& p_M : SampleMesh(*mesh, per_side, X_MS.translation)) {
    out.mesh_to_shape = std::max(out.mesh_to_shape, DistanceToShapeSurface(r.shape, X_MS.ToBody(p_M)));
  }
  const MeshBvh bvh(mesh);
  std::mt19937_64 rng(7);
  for (const Vector3& p_S : SampleShapeSurface(r.shape, spacing, rng)) {
    out.shape_to_mesh =
        std::max(out.shape_to_mesh, geometry::FindClosestPointOnMesh(bvh, X_MS.ToWorld(p_S)).distance);
  }
  return out;
}

std::string PinError(const std::shared_ptr<const TriangleMesh>& mesh, Representation pin) {
  try {
    ChooseMeshRepresentation(mesh, 1e-4, pin);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------
// Spheres

TEST(MeshRepresentation, IcosphereBecomesASphereAtALooseTolerance) {
  const auto mesh = Share(geometry::MakeIcosphere(16, 0.5));
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-3);
  ASSERT_EQ(r.choice.chosen, Representation::kSphere) << r.choice.reason;
  const auto& sphere = std::get<SphereShape>(r.shape);
  EXPECT_NEAR(sphere.radius, 0.5, 1e-3);
  EXPECT_LT(r.choice.X_MS.translation.norm(), 1e-12);
  EXPECT_TRUE(r.choice.X_MS.rotation.isIdentity(0));
  // the bound holds both ways, and is not loose
  const Measured measured = MeasureDeviation(mesh, r, 12, 0.01);
  EXPECT_GE(r.choice.error_bound, measured.mesh_to_shape);
  EXPECT_GE(r.choice.error_bound, measured.shape_to_mesh);
  EXPECT_LE(r.choice.error_bound, 2 * measured.both());
  EXPECT_LE(r.choice.error_bound, 1e-3);
  EXPECT_NE(r.choice.reason.find("sphere fit within"), std::string::npos) << r.choice.reason;
  EXPECT_NE(r.choice.reason.find("<= tolerance 0.001 m"), std::string::npos) << r.choice.reason;
}

TEST(MeshRepresentation, IcosphereStaysAMeshAtATightTolerance) {
  const auto mesh = Share(geometry::MakeIcosphere(16, 0.5));
  const double sphere_bound = ChooseMeshRepresentation(mesh, 1e-3).choice.error_bound;
  // tighter than the sphere fit: the mesh itself, never its hull (not cheaper)
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, sphere_bound / 2);
  ASSERT_EQ(r.choice.chosen, Representation::kMesh) << r.choice.reason;
  EXPECT_EQ(r.choice.error_bound, 0);
  EXPECT_NE(r.choice.reason.find("mesh kept, nothing cheaper within tolerance"), std::string::npos)
      << r.choice.reason;
  // pinned, the hull is the icosphere itself (it is convex), up to rounding
  const RepresentedMesh hull = ChooseMeshRepresentation(mesh, sphere_bound / 2, Representation::kConvex);
  ASSERT_EQ(hull.choice.chosen, Representation::kConvex) << hull.choice.reason;
  EXPECT_LT(hull.choice.error_bound, 1e-12);
  EXPECT_EQ(std::get<ConvexShape>(hull.shape).hull->num_vertices(), mesh->num_vertices());
  EXPECT_NE(hull.choice.reason.find("convex hull within"), std::string::npos) << hull.choice.reason;
}

TEST(MeshRepresentation, BumpySphereBoundHoldsBothWays) {
  // radial noise of 1%: still star-shaped around the centre, no longer convex
  const TriangleMesh smooth = geometry::MakeIcosphere(8, 1.0);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> noise(0.99, 1.01);
  std::vector<Vector3> vertices;
  for (const Vector3& v : smooth.vertices()) vertices.push_back(noise(rng) * v + Vector3(0.3, -0.2, 0.1));
  const auto mesh = Share(TriangleMesh(vertices, smooth.triangles()));
  for (Representation pin : {Representation::kSphere, Representation::kConvex}) {
    const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-4, pin);
    ASSERT_EQ(r.choice.chosen, pin);
    ASSERT_TRUE(std::isfinite(r.choice.error_bound)) << r.choice.reason;
    const Measured measured = MeasureDeviation(mesh, r, 6, 0.02);
    EXPECT_GE(r.choice.error_bound, measured.mesh_to_shape) << RepresentationName(pin);
    EXPECT_GE(r.choice.error_bound, measured.shape_to_mesh) << RepresentationName(pin);
    EXPECT_LE(r.choice.error_bound, 3 * measured.both()) << RepresentationName(pin);
    EXPECT_NE(r.choice.reason.find("pinned: "), std::string::npos);
  }
  // automatic at 2% picks the sphere, whose centre is the offset
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 0.02);
  ASSERT_EQ(r.choice.chosen, Representation::kSphere) << r.choice.reason;
  EXPECT_LT((r.choice.X_MS.translation - Vector3(0.3, -0.2, 0.1)).norm(), 5e-3);
}

// ---------------------------------------------------------------------------------
// Boxes

TEST(MeshRepresentation, BoxMeshBecomesItsBox) {
  const Vector3 h(0.5, 0.25, 1.0);
  const auto mesh = Share(geometry::MakeBoxMesh(h, 4));
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-6);
  ASSERT_EQ(r.choice.chosen, Representation::kBox) << r.choice.reason;
  EXPECT_EQ(std::get<BoxShape>(r.shape).half_extents, h);
  EXPECT_TRUE(r.choice.X_MS.rotation.isIdentity(0));
  EXPECT_EQ(r.choice.X_MS.translation, Vector3::Zero());
  EXPECT_LT(r.choice.error_bound, 1e-12);
  EXPECT_NE(r.choice.reason.find("box fit within"), std::string::npos) << r.choice.reason;
  // as a hull: coplanar mesh triangles lie in hull faces triangulated differently
  const RepresentedMesh hull = ChooseMeshRepresentation(mesh, 1e-6, Representation::kConvex);
  EXPECT_LT(hull.choice.error_bound, 1e-12) << hull.choice.reason;
}

TEST(MeshRepresentation, MovedBoxMeshIsFittedInItsPose) {
  std::mt19937_64 rng(3);
  const Vector3 h(0.3, 0.7, 0.2);
  for (int trial = 0; trial < 5; ++trial) {
    const Pose X{geometry::RandomRotation(rng), Vector3(1.5, -2, 0.25 * trial)};
    const auto mesh = Share(Transformed(geometry::MakeBoxMesh(h, 2), X));
    const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-6);
    ASSERT_EQ(r.choice.chosen, Representation::kBox) << r.choice.reason;
    EXPECT_LT(r.choice.error_bound, 1e-12);
    const Vector3 fitted = std::get<BoxShape>(r.shape).half_extents;
    const Pose& X_MS = r.choice.X_MS;
    EXPECT_LT((X_MS.rotation.transpose() * X_MS.rotation - Matrix3::Identity()).norm(), 1e-12);
    EXPECT_NEAR(X_MS.rotation.determinant(), 1, 1e-12);
    EXPECT_LT((X_MS.translation - X.translation).norm(), 1e-12);
    // the same box up to its symmetries: every fitted corner is a true corner
    for (int k = 0; k < 8; ++k) {
      const Vector3 s((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1);
      const Vector3 corner = X_MS.ToWorld(s.cwiseProduct(fitted));
      const Vector3 in_box = X.ToBody(corner);
      EXPECT_LT((in_box.cwiseAbs() - h).cwiseAbs().maxCoeff(), 1e-12) << "corner " << k;
    }
  }
}

TEST(MeshRepresentation, PinnedBoundsHoldForNoisyBoxes) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> noise(-1e-3, 1e-3);
  // a box with distinct principal axes, and a cube (whose principal axes are arbitrary)
  for (const Vector3& h : {Vector3(0.5, 0.4, 0.3), Vector3(0.4, 0.4, 0.4)}) {
    const Pose X{geometry::RandomRotation(rng), Vector3(0.1, 0.2, 0.3)};
    const TriangleMesh box = Transformed(geometry::MakeBoxMesh(h, 4), X);
    std::vector<Vector3> vertices;
    for (const Vector3& v : box.vertices()) vertices.push_back(v + Vector3(noise(rng), noise(rng), noise(rng)));
    const auto mesh = Share(TriangleMesh(vertices, box.triangles()));
    for (Representation pin : {Representation::kBox, Representation::kSphere,
                               Representation::kCapsule, Representation::kConvex}) {
      const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-4, pin);
      ASSERT_EQ(r.choice.chosen, pin);
      ASSERT_TRUE(std::isfinite(r.choice.error_bound)) << r.choice.reason;
      const Measured measured = MeasureDeviation(mesh, r, 6, 0.01);
      EXPECT_GE(r.choice.error_bound, measured.mesh_to_shape) << RepresentationName(pin);
      EXPECT_GE(r.choice.error_bound, measured.shape_to_mesh) << RepresentationName(pin);
    }
    // automatically, 1e-2 admits the box but not the sphere
    const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-2);
    EXPECT_EQ(r.choice.chosen, Representation::kBox) << r.choice.reason;
    EXPECT_LT((r.choice.X_MS.translation - X.translation).norm(), 2e-3);
  }
}

// ---------------------------------------------------------------------------------
// Capsules

TEST(MeshRepresentation, CapsuleMeshBecomesACapsule) {
  const double radius = 0.2, half_length = 0.5;
  const TriangleMesh local = MakeCapsuleMesh(radius, half_length, 12, 48);
  ASSERT_TRUE(local.is_closed());
  ASSERT_GT(local.signed_volume(), 0);
  std::mt19937_64 rng(9);
  const Pose X{geometry::RandomRotation(rng), Vector3(-0.5, 0.25, 2)};
  const auto mesh = Share(Transformed(local, X));
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 3e-3);
  ASSERT_EQ(r.choice.chosen, Representation::kCapsule) << r.choice.reason;
  const auto& capsule = std::get<CapsuleShape>(r.shape);
  EXPECT_NEAR(capsule.radius, radius, 3e-3);
  EXPECT_NEAR(capsule.half_length, half_length, 1e-9);
  // the axis is the mesh's z axis (either way), through its origin
  EXPECT_NEAR(std::abs(r.choice.X_MS.rotation.col(2).dot(X.rotation.col(2))), 1, 1e-9);
  EXPECT_LT((r.choice.X_MS.translation - X.translation).norm(), 1e-9);
  const Measured measured = MeasureDeviation(mesh, r, 8, 0.01);
  EXPECT_GE(r.choice.error_bound, measured.mesh_to_shape);
  EXPECT_GE(r.choice.error_bound, measured.shape_to_mesh);
  EXPECT_LE(r.choice.error_bound, 2 * measured.both());
}

// ---------------------------------------------------------------------------------
// Hulls and meshes

TEST(MeshRepresentation, ConvexMeshIsItsHullWhenPinned) {
  std::mt19937_64 rng(13);
  const std::vector<Vector3> cloud = geometry::RandomBall(rng, 300, 0.4, Vector3(1, 2, 3));
  const geometry::ConvexHull hull = geometry::BuildConvexHull(cloud);
  ASSERT_EQ(hull.dimension, 3);
  const auto mesh = Share(TriangleMesh(hull.vertices, hull.faces));
  // left to choose, the scene keeps the mesh (no primitive fits within 1e-4)
  EXPECT_EQ(ChooseMeshRepresentation(mesh, 1e-4).choice.chosen, Representation::kMesh);
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-4, Representation::kConvex);
  ASSERT_EQ(r.choice.chosen, Representation::kConvex) << r.choice.reason;
  EXPECT_LT(r.choice.error_bound, 1e-12);
  EXPECT_EQ(std::get<ConvexShape>(r.shape).hull->num_vertices(), hull.num_vertices());
  EXPECT_TRUE(r.choice.X_MS.rotation.isIdentity(0));
  EXPECT_EQ(r.choice.X_MS.translation, Vector3::Zero());
  // the cheaper candidates were tried and their numbers given
  EXPECT_NE(r.choice.reason.find("convex hull within"), std::string::npos) << r.choice.reason;
}

TEST(MeshRepresentation, TorusStaysAMesh) {
  const auto mesh = Share(geometry::MakeTorus(1.0, 0.3, 48, 24));
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 1e-2);
  ASSERT_EQ(r.choice.chosen, Representation::kMesh) << r.choice.reason;
  EXPECT_EQ(r.choice.error_bound, 0);
  const auto& bvh = std::get<MeshShape>(r.shape).bvh;
  ASSERT_NE(bvh, nullptr);
  EXPECT_EQ(&bvh->mesh(), mesh.get());
  EXPECT_NE(r.choice.reason.find("mesh kept"), std::string::npos) << r.choice.reason;
  EXPECT_NE(r.choice.reason.find("not star-shaped"), std::string::npos) << r.choice.reason;
}

TEST(MeshRepresentation, OpenMeshStaysAMesh) {
  // the upper half of an icosphere: nothing can be proven to cover a solid shape
  const TriangleMesh sphere = geometry::MakeIcosphere(6, 1.0);
  std::vector<Indices> upper;
  for (int t = 0; t < sphere.num_triangles(); ++t) {
    const Triangle tri = sphere.triangle(t);
    if (tri.v0.z() + tri.v1.z() + tri.v2.z() > 0) upper.push_back(sphere.triangles()[t]);
  }
  const auto mesh = Share(TriangleMesh(sphere.vertices(), upper));
  const RepresentedMesh r = ChooseMeshRepresentation(mesh, 0.5);
  EXPECT_EQ(r.choice.chosen, Representation::kMesh) << r.choice.reason;
  EXPECT_NE(r.choice.reason.find("the mesh is open"), std::string::npos) << r.choice.reason;
  EXPECT_EQ(r.choice.closure, geometry::MeshClosure::kOpen);
  ASSERT_EQ(r.choice.warnings.size(), 1u);
  EXPECT_EQ(r.choice.warnings[0],
            "the mesh is open (an edge has one triangle or more than two): it is a surface with no inside; "
            "distances to it are unsigned and nothing is inside it");
  // pinned as a primitive: no bound is proven, so the pin is refused naming it
  EXPECT_EQ(PinError(mesh, Representation::kSphere),
            "cannot represent the mesh as a sphere: its distance from the mesh has no finite bound (sphere "
            "(mesh within 0.00391 m of it) unproven: the mesh is open, so it need not cover the shape)");
  // its hull has a bound from the hull's faces, finite: accepted
  const RepresentedMesh as_hull = ChooseMeshRepresentation(mesh, 0.5, Representation::kConvex);
  EXPECT_TRUE(std::isfinite(as_hull.choice.error_bound));
}

TEST(MeshRepresentation, PinsAreHonoured) {
  const auto sphere = Share(geometry::MakeIcosphere(8, 1.0));
  const RepresentedMesh as_mesh = ChooseMeshRepresentation(sphere, 1.0, Representation::kMesh);
  EXPECT_EQ(as_mesh.choice.chosen, Representation::kMesh);
  EXPECT_NE(std::get<MeshShape>(as_mesh.shape).bvh, nullptr);
  EXPECT_EQ(as_mesh.choice.reason, "pinned: the mesh itself");
  const RepresentedMesh as_box = ChooseMeshRepresentation(sphere, 1e-9, Representation::kBox);
  EXPECT_EQ(as_box.choice.chosen, Representation::kBox);
  EXPECT_GT(as_box.choice.error_bound, 0.1);
  // a torus as its hull: nothing covers the hole, so the bound comes from the hull's
  // faces reaching back to their corners (mesh vertices): finite, at least the true
  // distance from the hull's top over the hole's centre down to the tube (0.744 m)
  const auto torus = Share(geometry::MakeTorus(1.0, 0.3, 24, 12));
  const RepresentedMesh as_hull = ChooseMeshRepresentation(torus, 1e-3, Representation::kConvex);
  EXPECT_EQ(as_hull.choice.chosen, Representation::kConvex);
  EXPECT_GE(as_hull.choice.error_bound, std::hypot(1.0, 0.3) - 0.3);
  EXPECT_LE(as_hull.choice.error_bound, 1.3);
  EXPECT_NE(as_hull.choice.reason.find("bounded by its faces' corners"), std::string::npos) << as_hull.choice.reason;
}

// A pin whose bound exceeds the tolerance is kept (the user chose it) with a warning
// naming both numbers; one within it has no warning; the torus pinned as a sphere (not
// star-shaped around its centre) has no finite bound and is refused.
TEST(MeshRepresentation, PinsBeyondTheToleranceAreWarnedAbout) {
  const auto sphere = Share(geometry::MakeIcosphere(8, 1.0));
  const RepresentedMesh as_box = ChooseMeshRepresentation(sphere, 1e-4, Representation::kBox);
  ASSERT_EQ(as_box.choice.warnings.size(), 1u);
  EXPECT_EQ(as_box.choice.warnings[0], "the pinned box is within " + FormatShort(as_box.choice.error_bound) +
                                           " m of the mesh, beyond the scene's tolerance 0.0001 m");
  const RepresentedMesh within = ChooseMeshRepresentation(sphere, 10, Representation::kBox);
  EXPECT_TRUE(within.choice.warnings.empty());
  EXPECT_TRUE(ChooseMeshRepresentation(sphere, 1e-4, Representation::kMesh).choice.warnings.empty());
  const auto torus = Share(geometry::MakeTorus(1.0, 0.3, 24, 12));
  EXPECT_NE(PinError(torus, Representation::kSphere).find("cannot represent the mesh as a sphere: its distance "
                                                          "from the mesh has no finite bound"),
            std::string::npos);
}

// An inside-out tetrahedron is rewound at validation: the choice says so, and its
// representation is the outward tetrahedron's.
TEST(MeshRepresentation, RewoundMeshesAreReported) {
  const std::vector<Vector3> vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const auto inside_out = Share(TriangleMesh(vertices, {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}}));
  const RepresentedMesh r = ChooseMeshRepresentation(inside_out, 1e-4);
  EXPECT_EQ(r.choice.chosen, Representation::kMesh);
  EXPECT_EQ(r.choice.closure, geometry::MeshClosure::kClosed);
  EXPECT_EQ(r.choice.rewound_triangles, 4);
  ASSERT_EQ(r.choice.warnings.size(), 1u);
  EXPECT_EQ(r.choice.warnings[0], "rewound 4 of 4 triangles so that the mesh's normals point out of its solid");
  EXPECT_GT(std::get<MeshShape>(r.shape).bvh->mesh().signed_volume(), 0);
}

TEST(MeshRepresentation, ImpossiblePinsAndBadArgumentsThrowNamingTheProblem) {
  // a flat square: no solid hull, no box
  const auto square = Share(TriangleMesh({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},
                                         {{0, 1, 2}, {0, 2, 3}}));
  EXPECT_EQ(PinError(square, Representation::kConvex),
            "cannot represent the mesh as a convex: the mesh's vertices are coplanar (hull "
            "dimension 2)");
  EXPECT_EQ(PinError(square, Representation::kBox),
            "cannot represent the mesh as a box: the mesh is flat along a box axis (half extents "
            "[0.5, 0.5, 0])");
  EXPECT_EQ(PinError(square, Representation::kSphere),
            "cannot represent the mesh as a sphere: its distance from the mesh has no finite bound (sphere "
            "(mesh within 0.354 m of it) unproven: the mesh is open, so it need not cover the shape)");
  EXPECT_EQ(ChooseMeshRepresentation(square, 1.0).choice.chosen, Representation::kMesh);
  EXPECT_EQ(PinError(square, static_cast<Representation>(17)), "representation 17 does not exist");
  for (double tolerance : {0.0, -1.0, std::nan(""), kInf}) {
    EXPECT_THROW(ChooseMeshRepresentation(square, tolerance), std::invalid_argument);
  }
  try {
    ChooseMeshRepresentation(square, -0.5);
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "tolerance is -0.5; it must be a finite number > 0");
  }
  EXPECT_THROW(ChooseMeshRepresentation(nullptr, 1e-3), std::invalid_argument);
}

TEST(MeshRepresentation, Names) {
  EXPECT_EQ(RepresentationName(Representation::kAuto), "auto");
  EXPECT_EQ(RepresentationName(Representation::kSphere), "sphere");
  EXPECT_EQ(RepresentationName(Representation::kBox), "box");
  EXPECT_EQ(RepresentationName(Representation::kCapsule), "capsule");
  EXPECT_EQ(RepresentationName(Representation::kConvex), "convex");
  EXPECT_EQ(RepresentationName(Representation::kMesh), "mesh");
}

// The time for 100k-triangle meshes (printed, not asserted: timings belong in bench/).
TEST(MeshRepresentation, LargeMeshesTakeReasonableTime) {
  using Clock = std::chrono::steady_clock;
  auto time = [](const std::shared_ptr<const TriangleMesh>& mesh, double tolerance) {
    const auto start = Clock::now();
    const RepresentedMesh r = ChooseMeshRepresentation(mesh, tolerance);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    std::cout << "  " << mesh->num_triangles() << " triangles, tolerance " << tolerance << ": "
              << RepresentationName(r.choice.chosen) << " in " << ms << " ms\n";
    return r.choice.chosen;
  };
  const auto sphere = Share(geometry::MakeIcosphere(71, 1.0));
  EXPECT_EQ(time(sphere, 1e-3), Representation::kSphere);
  EXPECT_EQ(time(sphere, 1e-9), Representation::kMesh);
  const auto torus = Share(geometry::MakeTorus(1.0, 0.3, 400, 125));
  EXPECT_EQ(time(torus, 1e-3), Representation::kMesh);
}

}  // namespace
}  // namespace hapticd::scene
