#include "server/geometry/mesh_queries.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/test/random_geometry.h"
#include "server/geometry/segment_triangle.h"

namespace hapticd::geometry {
namespace {

using Indices = TriangleMesh::TriangleIndices;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::shared_ptr<const TriangleMesh> Share(TriangleMesh mesh) {
  return std::make_shared<const TriangleMesh>(std::move(mesh));
}

// The same mesh with every coordinate rounded to a multiple of 2^-20 of its size, so
// that midpoints and v +- d are exact.
TriangleMesh OnGrid(const TriangleMesh& mesh) {
  const double scale = std::ldexp(1.0, 20) / mesh.size();
  std::vector<Vector3> vertices;
  for (const Vector3& v : mesh.vertices()) vertices.push_back((v * scale).array().round());
  return TriangleMesh(vertices, mesh.triangles());
}

TriangleMesh Reversed(const TriangleMesh& mesh) {
  std::vector<Indices> triangles = mesh.triangles();
  for (Indices& t : triangles) std::swap(t[1], t[2]);
  return TriangleMesh(mesh.vertices(), triangles);
}

struct NamedMesh {
  std::string name;
  std::shared_ptr<const TriangleMesh> mesh;
};

std::vector<NamedMesh> ClosedMeshes() {
  // a tall thin tetrahedron: its ridges are sharp enough (normals more than 90 degrees
  // apart) that a face normal alone puts points beside them on the wrong side
  TriangleMesh spike({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.3, 4}},
                     {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}});
  return {{"spike", Share(std::move(spike))},
          {"icosphere", Share(MakeIcosphere(9, 1.0))},
          {"torus", Share(MakeTorus(1.0, 0.35, 36, 18))},
          {"box", Share(MakeBoxMesh({0.5, 1, 0.75}, 5))},
          {"reversed torus", Share(Reversed(MakeTorus(1.0, 0.35, 30, 14)))}};
}

Vector3 RandomPointAround(const TriangleMesh& mesh, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-0.25, 1.25);
  const Aabb& b = mesh.bounds();
  return b.min + Vector3(unit(rng), unit(rng), unit(rng)).cwiseProduct(b.size());
}

// ---------------------------------------------------------------------------------
// Brute-force oracles: every non-degenerate triangle, no BVH; segments by the
// unfiltered exact test.

SegmentMeshHit BruteFirstHit(const TriangleMesh& mesh, const Vector3& p, const Vector3& q) {
  SegmentMeshHit best;
  for (int t : mesh.nondegenerate_triangles()) {
    const TriangleHit h = IntersectSegmentTriangleWatertightUnfiltered(p, q, mesh.triangle(t));
    if (h.hit && (!best.hit || h.t < best.t)) best = {true, h.t, t, h.u, h.v};
  }
  return best;
}

double BruteDistanceSquared(const TriangleMesh& mesh, const Vector3& p) {
  double best = kInf;
  for (int t : mesh.nondegenerate_triangles()) {
    best = std::min(best, FindClosestPointOnTriangle(p, mesh.triangle(t)).distance_squared);
  }
  return best;
}

// Inside by ray parity, decided with exact predicates: a ray from p in direction dir
// crosses triangle abc when p and the ray's travel are on opposite sides of its plane
// and the ray's line passes all three edges the same way. A ray that grazes an edge or
// vertex (a zero sign) is cast again in another random direction.
bool ParityInside(const TriangleMesh& mesh, const Vector3& p, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  while (true) {
    const Vector3 dir(normal(rng), normal(rng), normal(rng));
    int crossings = 0;
    bool grazing = false;
    for (int t : mesh.nondegenerate_triangles()) {
      const Triangle tri = mesh.triangle(t);
      const int side = Orient3d(tri.v0, tri.v1, tri.v2, p);
      const int approach = OrientLineEdge(tri.v0, dir, tri.v1, tri.v2);
      if (side * approach >= 0) continue;
      const int s0 = OrientLineEdge(p, dir, tri.v0, tri.v1);
      const int s1 = OrientLineEdge(p, dir, tri.v1, tri.v2);
      const int s2 = OrientLineEdge(p, dir, tri.v2, tri.v0);
      if (s0 == 0 || s1 == 0 || s2 == 0) {
        grazing = true;
        break;
      }
      if (s0 == s1 && s1 == s2) ++crossings;
    }
    if (!grazing) return crossings % 2 == 1;
  }
}

// ---------------------------------------------------------------------------------
// Segments.

void ExpectSameFirstHit(const MeshBvh& bvh, const Vector3& p, const Vector3& q,
                        const std::string& what) {
  const SegmentMeshHit got = FindFirstSegmentHit(bvh, p, q);
  const SegmentMeshHit want = BruteFirstHit(bvh.mesh(), p, q);
  ASSERT_EQ(got.hit, want.hit) << what;
  EXPECT_EQ(SegmentHitsMesh(bvh, p, q), want.hit) << what;
  if (!want.hit) return;
  // the same smallest t; the triangle may be another one holding that point
  EXPECT_EQ(got.t, want.t) << what;
  const TriangleHit again =
      IntersectSegmentTriangleWatertightUnfiltered(p, q, bvh.mesh().triangle(got.triangle));
  EXPECT_TRUE(again.hit) << what;
  EXPECT_EQ(again.t, got.t) << what;
  EXPECT_EQ(again.u, got.u) << what;
  EXPECT_EQ(again.v, got.v) << what;
}

TEST(MeshQueries, FirstHitMatchesBruteForce) {
  std::mt19937_64 rng(11);
  std::vector<NamedMesh> meshes = ClosedMeshes();
  meshes.push_back({"soup", Share(MakeRandomSoup(rng, 800, 0.1, 17, 3))});
  std::normal_distribution<double> normal;
  for (const NamedMesh& m : meshes) {
    const MeshBvh bvh(m.mesh);
    const double size = m.mesh->size();
    for (int k = 0; k < 600; ++k) {
      const Vector3 p = RandomPointAround(*m.mesh, rng);
      // long segments, and short ones (1% of the size)
      const Vector3 step = 0.01 * size * Vector3(normal(rng), normal(rng), normal(rng));
      const Vector3 q = k % 2 == 0 ? RandomPointAround(*m.mesh, rng) : Vector3(p + step);
      ExpectSameFirstHit(bvh, p, q, m.name + " segment " + std::to_string(k));
    }
  }
}

TEST(MeshQueries, AxisAlignedSegmentsMatchBruteForce) {
  // zero direction components give infinite and NaN slab distances in the BVH
  const MeshBvh bvh(Share(MakeBoxMesh({1, 1, 1}, 4)));
  std::mt19937_64 rng(12);
  std::uniform_int_distribution<int> grid(-6, 6);
  for (int k = 0; k < 2000; ++k) {
    const Vector3 p = Vector3(grid(rng), grid(rng), grid(rng)) / 4;
    Vector3 q = p;
    q[k % 3] += grid(rng) / 2.0;
    if (p == q) continue;
    ExpectSameFirstHit(bvh, p, q, "axis segment " + std::to_string(k));
  }
}

// A segment through a vertex or an edge of a closed mesh touches the surface there,
// so it must hit, whatever its direction (unless it lies in every plane around it).
TEST(MeshQueries, SegmentsAimedThroughVerticesAndEdgesNeverSlipThrough) {
  std::mt19937_64 rng(13);
  std::uniform_int_distribution<int> small(-1000, 1000);
  int aims = 0;
  for (const NamedMesh& m : ClosedMeshes()) {
    const auto mesh = Share(OnGrid(*m.mesh));
    const MeshBvh bvh(mesh);
    auto aim = [&](const Vector3& target, const std::string& what) {
      const Vector3 d(small(rng), small(rng), small(rng) + 2000);
      const Vector3 p = target + d, q = target - d;
      // skip a segment lying in the plane of a flat region (then nothing is hit)
      for (int t : mesh->nondegenerate_triangles()) {
        const Triangle tri = mesh->triangle(t);
        if (!Aabb::OfTriangle(tri).Contains(target)) continue;
        if (Orient3d(tri.v0, tri.v1, tri.v2, p) == 0 && Orient3d(tri.v0, tri.v1, tri.v2, q) == 0) {
          return;
        }
      }
      ++aims;
      const SegmentMeshHit hit = FindFirstSegmentHit(bvh, p, q);
      ASSERT_TRUE(hit.hit) << m.name << " " << what;
      EXPECT_LE(hit.t, 0.5 + 1e-12) << m.name << " " << what;
      EXPECT_TRUE(SegmentHitsMesh(bvh, p, q)) << m.name << " " << what;
      // and the first hit is the brute-force one (on a sample, to keep the test short)
      if (aims % 8 == 0) ExpectSameFirstHit(bvh, p, q, m.name + " " + what);
    };
    for (int v = 0; v < mesh->num_vertices(); ++v) {
      aim(mesh->vertices()[v], "vertex " + std::to_string(v));
    }
    for (const Indices& t : mesh->triangles()) {
      aim(0.5 * (mesh->vertices()[t[0]] + mesh->vertices()[t[1]]), "edge midpoint");
      aim(0.25 * mesh->vertices()[t[1]] + 0.75 * mesh->vertices()[t[2]], "edge quarter");
    }
  }
  EXPECT_GT(aims, 10000);
}

// The same mesh moved by `offset` (each vertex rounded to double once).
TriangleMesh Moved(const TriangleMesh& mesh, const Vector3& offset) {
  std::vector<Vector3> vertices;
  for (const Vector3& v : mesh.vertices()) vertices.push_back(v + offset);
  return TriangleMesh(vertices, mesh.triangles());
}

// The BVH traverses segments in float: the origin is rounded to float and every slab
// distance is rounded, so a box the exact segment touches must still be entered. Far
// from the origin a float ulp is as large as a triangle (here 1e6 and 3e7 away, size
// 1e-2 and 1: ulps of 0.06 and 2), and segments start on, end on and graze vertices,
// edges and faces, long and very short.
TEST(MeshQueries, FloatTraversalMissesNoBoxFarFromTheOrigin) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0, 1);
  struct Case {
    std::string name;
    std::shared_ptr<const TriangleMesh> mesh;
  };
  const std::vector<Case> cases = {
      {"torus at 1e6", Share(Moved(MakeTorus(0.01, 0.004, 20, 10), {1e6, -1e6, 3e5}))},
      {"icosphere at 3e7", Share(Moved(MakeIcosphere(6, 1.0), {-3e7, 2e7, 1e7}))},
      {"box at 1e6", Share(Moved(MakeBoxMesh({0.01, 0.02, 0.015}, 3), {1e6, 1e6, -1e6}))},
      {"box near 0", Share(MakeBoxMesh({1e-3, 2e-3, 1.5e-3}, 3))},
  };
  for (const Case& c : cases) {
    const MeshBvh bvh(c.mesh);
    const double size = c.mesh->size();
    const auto& vertices = c.mesh->vertices();
    std::uniform_int_distribution<int> pick_triangle(0, c.mesh->num_triangles() - 1);
    for (int k = 0; k < 3000; ++k) {
      const Indices& t = c.mesh->triangles()[pick_triangle(rng)];
      // a target on the surface: a vertex, an edge point or a face point
      double u = unit(rng), v = unit(rng);
      if (k % 3 == 0) u = v = 0;
      if (k % 3 == 1) v = 1 - u;
      if (u + v > 1) u = 1 - u, v = 1 - v;
      const Vector3 target = (1 - u - v) * vertices[t[0]] + u * vertices[t[1]] + v * vertices[t[2]];
      const Vector3 dir = Vector3(normal(rng), normal(rng), normal(rng)).normalized();
      // lengths from 1e-9 to 1 of the size; the target at an end, inside or beyond
      const double length = size * std::pow(10.0, -9 * unit(rng));
      const double where[] = {0, 1, 0.5, unit(rng), 1 + unit(rng)};
      const Vector3 p = target - where[k % 5] * length * dir;
      const Vector3 q = p + length * dir;
      if (p == q) continue;
      ExpectSameFirstHit(bvh, p, q, c.name + " segment " + std::to_string(k));
      if (HasFailure()) return;
    }
  }
}

// Near the origin the float traversal's widened origin is a subnormal, so only its
// relative slack keeps a box that the segment touches at a single point: here a segment
// from the origin passes through a triangle's vertex at the corner of its box where it
// enters the x slab at exactly the t where it leaves the y slab (1 / k). In float the
// two t come from differently rounded reciprocals, so about half the time the entry is
// an ulp after the exit; the coordinates are small integers, so the float boxes are
// exact and give no room of their own.
TEST(MeshQueries, FloatTraversalEntersABoxTouchedAtOneCornerFromTheOrigin) {
  std::mt19937_64 rng(1205);
  std::uniform_int_distribution<int> coordinate(1, 1000);
  std::uniform_int_distribution<int> stretch(2, 97);
  int hits = 0;
  for (int k = 0; k < 2000; ++k) {
    const double a = coordinate(rng), b = coordinate(rng), c = stretch(rng);
    // the vertex (a, b, 0) is its box's least x and greatest y; the triangle leans out
    // of z = 0, so the segment (in z = 0) crosses its plane there
    const std::vector<Vector3> vertices = {{a, b, 0}, {a + 1, b, 1}, {a + 1, b - 1, 1}};
    const MeshBvh bvh(Share(TriangleMesh(vertices, {{0, 1, 2}})));
    const Vector3 p = Vector3::Zero(), q(c * a, c * b, 0);
    ExpectSameFirstHit(bvh, p, q, "corner " + std::to_string(k));
    if (HasFailure()) return;
    hits += BruteFirstHit(bvh.mesh(), p, q).hit;
  }
  // the exact test counts the vertex as touched: the case is not vacuous
  EXPECT_GT(hits, 1000);
}

// Segments float cannot carry (coordinates beyond 1e30, direction components below
// 1e-37 but not zero) take the double traversal, and still match brute force.
TEST(MeshQueries, SegmentsBeyondFloatTakeTheDoubleTraversal) {
  const MeshBvh big(Share(MakeIcosphere(4, 1e31)));
  ExpectSameFirstHit(big, Vector3(3e31, 1e29, -2e29), Vector3(-3e31, 0, 1e28), "beyond float");
  ExpectSameFirstHit(big, Vector3(3e31, 0, 0), Vector3(0.5e31, 0, 0), "beyond float, axis");
  const MeshBvh unit(Share(MakeIcosphere(4, 1.0)));
  for (const double tiny : {1e-38, 1e-45, 1e-300}) {
    ExpectSameFirstHit(unit, Vector3(2, 0.1, 0.2), Vector3(-2, 0.1 + tiny, 0.2), "tiny component");
    ExpectSameFirstHit(unit, Vector3(0.1, 0.2, 2), Vector3(0.1, 0.2 - tiny, 0.5), "tiny component");
    ExpectSameFirstHit(unit, Vector3(0.1, 0.2, 2), Vector3(0.1, 0.2 - tiny, 0.999), "tiny, short");
  }
}

TEST(MeshQueries, DegenerateSegmentsAndNonFiniteInputMiss) {
  const MeshBvh bvh(Share(MakeIcosphere(4, 1.0)));
  const Vector3 on = bvh.mesh().vertices()[0];
  // zero length (a precondition violation) is a miss, even on the surface
  EXPECT_FALSE(FindFirstSegmentHit(bvh, on, on).hit);
  EXPECT_FALSE(SegmentHitsMesh(bvh, on, on));
  for (const Vector3& bad : {Vector3(kNan, 0, 0), Vector3(0, kInf, 0), Vector3(0, 0, -kInf)}) {
    EXPECT_FALSE(FindFirstSegmentHit(bvh, bad, Vector3::Zero()).hit);
    EXPECT_FALSE(FindFirstSegmentHit(bvh, Vector3(2, 0, 0), bad).hit);
    EXPECT_FALSE(SegmentHitsMesh(bvh, bad, Vector3::Zero()));
    EXPECT_FALSE(FindClosestPointOnMesh(bvh, bad).found);
    EXPECT_FALSE(IsPointInsideMesh(bvh, bad));
    SphereMeshContact buffer[4];
    EXPECT_EQ(FindSphereMeshContacts(bvh, {bad, 1.0}, buffer).num_touching, 0);
  }
  SphereMeshContact buffer[4];
  EXPECT_EQ(FindSphereMeshContacts(bvh, {Vector3::Zero(), kNan}, buffer).num_touching, 0);
  EXPECT_EQ(FindSphereMeshContacts(bvh, {Vector3::Zero(), -1}, buffer).num_touching, 0);
  EXPECT_EQ(FindSphereMeshContacts(bvh, {Vector3::Zero(), kInf}, buffer).num_touching, 0);
  EXPECT_FALSE(FindClosestPointOnMesh(bvh, Vector3::Zero(), kNan).found);
  EXPECT_FALSE(FindClosestPointOnMesh(bvh, Vector3::Zero(), -1).found);
}

TEST(MeshQueries, HandBuiltBoxHits) {
  // box [-1, 1]^3 with 2x2 squares per face: dyadic, so every answer is exact
  const MeshBvh bvh(Share(MakeBoxMesh({1, 1, 1}, 2)));
  // straight through the centre of the +z face (a shared vertex of 6 triangles)
  SegmentMeshHit hit = FindFirstSegmentHit(bvh, {0, 0, 3}, {0, 0, -3});
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 1.0 / 3);
  // ending exactly on the surface: touching counts, at t = 1
  hit = FindFirstSegmentHit(bvh, {0.25, 0.5, 2}, {0.25, 0.5, 1});
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 1);
  // lying in the face plane z = 1 across the face: every triangle there is coplanar,
  // but it enters the side faces x = +-1 at their top edge
  hit = FindFirstSegmentHit(bvh, {-2, 0.25, 1}, {2, 0.25, 1});
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 0.25);
  // just above the face: a miss
  EXPECT_FALSE(SegmentHitsMesh(bvh, {-0.5, 0.25, 1 + 1e-12}, {0.5, 0.25, 1 + 1e-12}));
}

// ---------------------------------------------------------------------------------
// Closest points.

TEST(MeshQueries, ClosestPointMatchesBruteForce) {
  std::mt19937_64 rng(21);
  std::vector<NamedMesh> meshes = ClosedMeshes();
  meshes.push_back({"soup", Share(MakeRandomSoup(rng, 800, 0.1, 17, 3))});
  std::uniform_real_distribution<double> unit(0, 1);
  for (const NamedMesh& m : meshes) {
    const MeshBvh bvh(m.mesh);
    const double size = m.mesh->size();
    for (int k = 0; k < 600; ++k) {
      const Vector3 p = RandomPointAround(*m.mesh, rng);
      const std::string what = m.name + " point " + std::to_string(k);
      const double want = std::sqrt(BruteDistanceSquared(*m.mesh, p));
      const MeshClosestPoint got = FindClosestPointOnMesh(bvh, p);
      ASSERT_TRUE(got.found) << what;
      EXPECT_NEAR(got.distance, want, 1e-12 * size) << what;
      // the reported point is on the reported triangle, at the reported distance
      const ClosestPointOnTriangle on =
          FindClosestPointOnTriangle(p, m.mesh->triangle(got.triangle));
      EXPECT_EQ(on.point, got.point) << what;
      EXPECT_EQ(on.feature, got.feature) << what;
      EXPECT_NEAR((got.point - p).norm(), got.distance, 1e-12 * size) << what;
      EXPECT_FALSE(m.mesh->is_degenerate(got.triangle)) << what;
      // a radius keeps or drops it, away from the boundary
      const double factor = 0.5 + unit(rng);
      if (std::abs(factor - 1) > 1e-6) {
        EXPECT_EQ(FindClosestPointOnMesh(bvh, p, factor * want).found, factor > 1) << what;
      }
    }
  }
}

TEST(MeshQueries, ClosestPointOnTheSurfaceIsExact) {
  const MeshBvh bvh(Share(MakeBoxMesh({1, 1, 1}, 2)));
  for (const Vector3& p : {Vector3(0.25, -0.75, 1), Vector3(1, 1, 1), Vector3(1, 0.5, -1)}) {
    const MeshClosestPoint c = FindClosestPointOnMesh(bvh, p, 1e-15);
    ASSERT_TRUE(c.found);
    EXPECT_LE(c.distance, 1e-15);
    EXPECT_LE((c.point - p).norm(), 1e-15);
  }
  // a radius just short of the gap finds nothing; the exact gap finds it
  EXPECT_FALSE(FindClosestPointOnMesh(bvh, {0, 0, 3}, 1.999).found);
  EXPECT_TRUE(FindClosestPointOnMesh(bvh, {0, 0, 3}, 2.0).found);
}

// ---------------------------------------------------------------------------------
// Sphere contacts.

TEST(MeshQueries, SphereContactsMatchBruteForce) {
  std::mt19937_64 rng(31);
  std::vector<NamedMesh> meshes = ClosedMeshes();
  meshes.push_back({"soup", Share(MakeRandomSoup(rng, 800, 0.1, 17, 3))});
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<SphereMeshContact> buffer(4096);
  for (const NamedMesh& m : meshes) {
    const MeshBvh bvh(m.mesh);
    const double size = m.mesh->size();
    for (int k = 0; k < 300; ++k) {
      const Sphere sphere{RandomPointAround(*m.mesh, rng), 0.2 * size * unit(rng)};
      const std::string what = m.name + " sphere " + std::to_string(k);
      const SphereMeshContacts got = FindSphereMeshContacts(bvh, sphere, buffer);
      // brute force: the triangles within the radius, with their contact
      std::vector<SphereMeshContact> want;
      for (int t : m.mesh->nondegenerate_triangles()) {
        const ClosestPointOnTriangle c =
            FindClosestPointOnTriangle(sphere.center, m.mesh->triangle(t));
        if (c.distance_squared <= sphere.radius * sphere.radius) {
          const double d = std::sqrt(c.distance_squared);
          want.push_back({t, c.point, (sphere.center - c.point) / d, sphere.radius - d, c.feature});
        }
      }
      ASSERT_EQ(got.num_touching, static_cast<int>(want.size())) << what;
      ASSERT_EQ(got.count, got.num_touching) << what;
      EXPECT_FALSE(got.truncated) << what;
      std::vector<SphereMeshContact> sorted(buffer.begin(), buffer.begin() + got.count);
      std::sort(sorted.begin(), sorted.end(),
                [](const auto& a, const auto& b) { return a.triangle < b.triangle; });
      for (size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ(sorted[i].triangle, want[i].triangle) << what;
        EXPECT_EQ(sorted[i].point, want[i].point) << what;
        EXPECT_EQ(sorted[i].feature, want[i].feature) << what;
        EXPECT_NEAR(sorted[i].depth, want[i].depth, 1e-15 * size) << what;
        EXPECT_LT((sorted[i].normal - want[i].normal).norm(), 1e-9) << what;
      }
      // a small buffer keeps the deepest
      SphereMeshContact small[3];
      const SphereMeshContacts cut = FindSphereMeshContacts(bvh, sphere, small);
      EXPECT_EQ(cut.num_touching, got.num_touching) << what;
      EXPECT_EQ(cut.count, std::min(3, got.num_touching)) << what;
      EXPECT_EQ(cut.truncated, got.num_touching > 3) << what;
      std::vector<double> depths, kept;
      for (const auto& c : want) depths.push_back(c.depth);
      for (int i = 0; i < cut.count; ++i) kept.push_back(small[i].depth);
      std::sort(depths.rbegin(), depths.rend());
      std::sort(kept.rbegin(), kept.rend());
      for (int i = 0; i < cut.count; ++i) EXPECT_EQ(kept[i], depths[i]) << what;
    }
  }
}

TEST(MeshQueries, SphereTouchingAFaceHasDepthZeroAndCentreOnFaceUsesFaceNormal) {
  const MeshBvh bvh(Share(MakeBoxMesh({1, 1, 1}, 1)));
  SphereMeshContact buffer[16];
  // touching the +z face from above, away from its diagonal: one contact, depth 0
  SphereMeshContacts r = FindSphereMeshContacts(bvh, {{0.5, -0.25, 1.5}, 0.5}, buffer);
  ASSERT_EQ(r.count, 1);
  EXPECT_NEAR(buffer[0].depth, 0, 1e-15);
  EXPECT_EQ(buffer[0].normal, Vector3(0, 0, 1));
  EXPECT_LE((buffer[0].point - Vector3(0.5, -0.25, 1)).norm(), 1e-15);
  // centred on the face: no gap to take a direction from
  r = FindSphereMeshContacts(bvh, {{0.5, -0.25, 1}, 0.25}, buffer);
  ASSERT_EQ(r.count, 1);
  EXPECT_NEAR(buffer[0].depth, 0.25, 1e-15);
  EXPECT_EQ(buffer[0].normal, Vector3(0, 0, 1));
  // centred just below the face: the normal turns with the centre's side
  r = FindSphereMeshContacts(bvh, {{0.5, -0.25, 0.875}, 0.25}, buffer);
  ASSERT_EQ(r.count, 1);
  EXPECT_EQ(buffer[0].normal, Vector3(0, 0, -1));
  // an empty buffer still counts
  r = FindSphereMeshContacts(bvh, {{0, 0, 0}, 5}, std::span<SphereMeshContact>());
  EXPECT_EQ(r.count, 0);
  EXPECT_EQ(r.num_touching, 12);
  EXPECT_TRUE(r.truncated);
}

// ---------------------------------------------------------------------------------
// Inside / outside.

TEST(MeshQueries, InsideMatchesExactRayParity) {
  std::mt19937_64 rng(41);
  for (const NamedMesh& m : ClosedMeshes()) {
    ASSERT_TRUE(m.mesh->is_closed()) << m.name;
    const MeshBvh bvh(m.mesh);
    const double size = m.mesh->size();
    int inside = 0, tested = 0;
    while (tested < 400) {
      const Vector3 p = RandomPointAround(*m.mesh, rng);
      const double d = std::sqrt(BruteDistanceSquared(*m.mesh, p));
      // away from the surface: where the answer is not a matter of rounding
      if (d < 1e-3 * size) continue;
      ++tested;
      const bool want = ParityInside(*m.mesh, p, rng);
      inside += want;
      const MeshSignedDistance got = CalcSignedDistanceToMesh(bvh, p);
      ASSERT_EQ(got.inside, want) << m.name << " point " << p.transpose();
      EXPECT_EQ(IsPointInsideMesh(bvh, p), want);
      EXPECT_NEAR(std::abs(got.signed_distance), d, 1e-12 * size);
      EXPECT_EQ(got.signed_distance < 0, want);
    }
    EXPECT_GT(inside, 5) << m.name;  // both answers were exercised
    EXPECT_LT(inside, 395) << m.name;
  }
}

// Near vertices and edges the closest feature is a vertex or an edge, where a face
// normal can give the wrong side (at saddles and concave edges) and only the
// pseudo-normal is right.
TEST(MeshQueries, InsideNearVerticesAndEdgesMatchesExactRayParity) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal;
  for (const NamedMesh& m : ClosedMeshes()) {
    const MeshBvh bvh(m.mesh);
    const double size = m.mesh->size();
    for (int k = 0; k < 300; ++k) {
      const Indices& t = m.mesh->triangles()[k * 7 % m.mesh->num_triangles()];
      const Vector3 a = m.mesh->vertices()[t[0]], b = m.mesh->vertices()[t[1]];
      const Vector3 near = k % 2 == 0 ? a : Vector3(0.5 * (a + b));
      const Vector3 p = near + 2e-3 * size * Vector3(normal(rng), normal(rng), normal(rng));
      if (BruteDistanceSquared(*m.mesh, p) < 1e-10 * size * size) continue;
      EXPECT_EQ(IsPointInsideMesh(bvh, p), ParityInside(*m.mesh, p, rng))
          << m.name << " point " << p.transpose();
    }
  }
}

// Points exactly on the surface (on a 2^-20 grid, so that they are representable) are
// inside, even where the computed closest point is a rounding error away.
TEST(MeshQueries, PointsOnTheSurfaceAreInside) {
  for (const NamedMesh& m : ClosedMeshes()) {
    const auto mesh = Share(OnGrid(*m.mesh));
    const MeshBvh bvh(mesh);
    for (const Vector3& v : mesh->vertices()) {
      EXPECT_TRUE(IsPointInsideMesh(bvh, v)) << m.name;
    }
    for (const Indices& t : mesh->triangles()) {
      const Vector3 a = mesh->vertices()[t[0]], b = mesh->vertices()[t[1]],
                    c = mesh->vertices()[t[2]];
      EXPECT_TRUE(IsPointInsideMesh(bvh, 0.5 * (a + b))) << m.name << " edge midpoint";
      EXPECT_TRUE(IsPointInsideMesh(bvh, 0.25 * (3 * b + c))) << m.name << " edge quarter";
      const Vector3 in_face = 0.25 * (2 * a + b + c);
      const MeshSignedDistance s = CalcSignedDistanceToMesh(bvh, in_face);
      EXPECT_TRUE(s.inside) << m.name << " face point";
      EXPECT_EQ(s.signed_distance, 0) << m.name << " face point";
      EXPECT_EQ(s.closest.point, in_face) << m.name << " face point";
    }
  }
  // points inside a face, exactly on it, and a hair outside or inside
  const MeshBvh box(Share(MakeBoxMesh({1, 1, 1}, 2)));
  const MeshSignedDistance on = CalcSignedDistanceToMesh(box, {0.375, -0.625, 1});
  EXPECT_TRUE(on.inside);
  EXPECT_EQ(on.signed_distance, 0);
  EXPECT_FALSE(IsPointInsideMesh(box, {0.375, -0.625, 1 + 1e-15}));
  EXPECT_TRUE(IsPointInsideMesh(box, {0.375, -0.625, 1 - 1e-15}));
  EXPECT_EQ(CalcSignedDistanceToMesh(box, {0, 0, 0.5}).signed_distance, -0.5);
  EXPECT_EQ(CalcSignedDistanceToMesh(box, {0, 3, 0}).signed_distance, 2);
  // near a corner and an edge, outside: the vertex and edge pseudo-normals decide
  EXPECT_FALSE(IsPointInsideMesh(box, {1.25, 1.125, 1.0625}));
  EXPECT_FALSE(IsPointInsideMesh(box, {1.25, 1.125, 0.5}));
  EXPECT_TRUE(IsPointInsideMesh(box, {0.875, 0.9375, 0.5}));
}

}  // namespace
}  // namespace hapticd::geometry
