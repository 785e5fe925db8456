#include "server/geometry/segment_triangle.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

const Triangle kTri{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};

using SegmentQuery = TriangleHit (*)(const Vector3&, const Vector3&, const Triangle&);
struct Flavour {
  const char* name;
  SegmentQuery segment;
  SegmentQuery ray;
};
const Flavour kFlavours[] = {
    {"moller_trumbore", IntersectSegmentTriangle, IntersectRayTriangle},
    {"watertight", IntersectSegmentTriangleWatertight, IntersectRayTriangleWatertight},
};

void ExpectHit(const TriangleHit& h, double t, double u, double v, const char* what) {
  EXPECT_TRUE(h.hit) << what;
  if (!h.hit) return;
  EXPECT_NEAR(h.t, t, 1e-15) << what;
  EXPECT_NEAR(h.u, u, 1e-15) << what;
  EXPECT_NEAR(h.v, v, 1e-15) << what;
}

// ---------------------------------------------------------------------------------
// Hand-built cases; dyadic coordinates and power-of-two determinants keep even the
// floating-point test exact, so both flavours must agree with the exact answers.

TEST(SegmentTriangle, ThroughTheFace) {
  for (const Flavour& f : kFlavours) {
    ExpectHit(f.segment({1, 2, 1}, {1, 2, -1}, kTri), 0.5, 0.25, 0.5, f.name);
    // reversed segment: t mirrored
    ExpectHit(f.segment({1, 2, -1}, {1, 2, 1}, kTri), 0.5, 0.25, 0.5, f.name);
    // reversed winding: u and v swap
    ExpectHit(f.segment({1, 2, 1}, {1, 2, -1}, {kTri.v0, kTri.v2, kTri.v1}), 0.5, 0.5, 0.25,
              f.name);
    // oblique
    ExpectHit(f.segment({0, 0, 2}, {2, 2, -2}, kTri), 0.5, 0.25, 0.25, f.name);
  }
}

TEST(SegmentTriangle, TouchingVertexEdgeAndEndpointCountsAsHit) {
  for (const Flavour& f : kFlavours) {
    ExpectHit(f.segment({4, 0, 1}, {4, 0, -1}, kTri), 0.5, 1, 0, f.name);      // vertex v1
    ExpectHit(f.segment({0, 0, 2}, {0, 0, -2}, kTri), 0.5, 0, 0, f.name);      // vertex v0
    ExpectHit(f.segment({2, 0, 1}, {2, 0, -1}, kTri), 0.5, 0.5, 0, f.name);    // edge v0-v1
    ExpectHit(f.segment({2, 2, 1}, {2, 2, -3}, kTri), 0.25, 0.5, 0.5, f.name); // edge v1-v2
    ExpectHit(f.segment({0, 1, 1}, {0, 1, -1}, kTri), 0.5, 0, 0.25, f.name);   // edge v2-v0
    ExpectHit(f.segment({1, 1, 0}, {1, 1, 1}, kTri), 0, 0.25, 0.25, f.name);   // p on the face
    ExpectHit(f.segment({1, 1, -1}, {1, 1, 0}, kTri), 1, 0.25, 0.25, f.name);  // q on the face
    ExpectHit(f.segment({2, 0, 0}, {3, 1, 1}, kTri), 0, 0.5, 0, f.name);       // p on an edge
  }
}

TEST(SegmentTriangle, WatertightTouchingIsExactAtGenericCoordinates) {
  // touches at coordinates where floating point rounds: exact decision and exact
  // barycentrics at the touched vertex
  const Triangle t{{0.1, 0.2, 0.3}, {1.7, 0.1, -0.3}, {0.3, 1.9, 0.7}};
  // 2 v1 -> v1 / 2 passes exactly through v1 (radially from the origin, which is off
  // the triangle's plane), at t = 2/3
  const TriangleHit h = IntersectSegmentTriangleWatertight(2 * t.v1, 0.5 * t.v1, t);
  EXPECT_TRUE(h.hit);
  EXPECT_EQ(h.u, 1);
  EXPECT_EQ(h.v, 0);
  EXPECT_NEAR(h.t, 2.0 / 3, 1e-15);
  // a segment ending exactly at a vertex
  const TriangleHit e = IntersectSegmentTriangleWatertight(2 * t.v2, t.v2, t);
  EXPECT_TRUE(e.hit);
  EXPECT_EQ(e.t, 1);
  EXPECT_EQ(e.u, 0);
  EXPECT_EQ(e.v, 1);
}

TEST(SegmentTriangle, InPlaneAndParallelSegmentsMiss) {
  for (const Flavour& f : kFlavours) {
    // in the plane, crossing the triangle: a miss by convention
    EXPECT_FALSE(f.segment({-1, 1, 0}, {5, 1, 0}, kTri).hit) << f.name;
    EXPECT_FALSE(f.segment({1, 1, 0}, {2, 1, 0}, kTri).hit) << f.name;
    EXPECT_FALSE(f.ray({-1, 1, 0}, {1, 0, 0}, kTri).hit) << f.name;
    // parallel above
    EXPECT_FALSE(f.segment({-1, 1, 1}, {5, 1, 1}, kTri).hit) << f.name;
    EXPECT_FALSE(f.ray({-1, 1, 1}, {1, 0, 0}, kTri).hit) << f.name;
  }
}

TEST(SegmentTriangle, ShortOutsideAndBehindMiss) {
  const double tiny = std::ldexp(1.0, -40);
  for (const Flavour& f : kFlavours) {
    EXPECT_FALSE(f.segment({1, 1, 2}, {1, 1, tiny}, kTri).hit) << f.name;       // ends short
    EXPECT_FALSE(f.segment({1, 1, -tiny}, {1, 1, -2}, kTri).hit) << f.name;     // starts past
    EXPECT_FALSE(f.segment({4, tiny, 1}, {4, tiny, -1}, kTri).hit) << f.name;   // beside v1
    EXPECT_FALSE(f.segment({2 + tiny, 2, 1}, {2 + tiny, 2, -1}, kTri).hit) << f.name;
    EXPECT_FALSE(f.segment({-tiny, 1, 1}, {-tiny, 1, -1}, kTri).hit) << f.name;
    EXPECT_FALSE(f.ray({1, 1, -1}, {0, 0, -1}, kTri).hit) << f.name;            // away
  }
}

TEST(RayTriangle, HitsOriginOnFaceAndScalesWithDirection) {
  for (const Flavour& f : kFlavours) {
    ExpectHit(f.ray({1, 2, 4}, {0, 0, -1}, kTri), 4, 0.25, 0.5, f.name);
    ExpectHit(f.ray({1, 2, 4}, {0, 0, -8}, kTri), 0.5, 0.25, 0.5, f.name);
    ExpectHit(f.ray({1, 2, 4}, {0, 0, -0.125}, kTri), 32, 0.25, 0.5, f.name);
    // origin on the face: t = 0, whichever way the ray goes
    ExpectHit(f.ray({1, 1, 0}, {0, 0, 1}, kTri), 0, 0.25, 0.25, f.name);
    ExpectHit(f.ray({1, 1, 0}, {1, 2, -1}, kTri), 0, 0.25, 0.25, f.name);
    // through a vertex, far away
    ExpectHit(f.ray({0, 4, 1024}, {0, 0, -1}, kTri), 1024, 0, 1, f.name);
  }
}

// Non-finite input is a miss in both flavours (Möller-Trumbore's comparisons reject NaN;
// the watertight test checks first, since its exact signs would be meaningless).
TEST(SegmentTriangle, NonFiniteInputIsAMiss) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {nan, inf, -inf}) {
    const Vector3 bad_point(1, bad, 1);
    const Triangle bad_tri{{0, 0, 0}, {4, 0, bad}, {0, 4, 0}};
    for (const Flavour& f : kFlavours) {
      EXPECT_FALSE(f.segment(bad_point, {1, 1, -1}, kTri).hit) << f.name << " " << bad;
      EXPECT_FALSE(f.segment({1, 1, 1}, {1, 1, -1}, bad_tri).hit) << f.name << " " << bad;
      EXPECT_FALSE(f.ray({1, 1, 1}, {0, bad, -1}, kTri).hit) << f.name << " " << bad;
      EXPECT_FALSE(f.ray({1, 1, 1}, {0, 0, -1}, bad_tri).hit) << f.name << " " << bad;
    }
  }
}

// A fuzz find (regressions/fuzz_mesh_validation/nan-sweep-on-tiny-coordinates): the
// segment crosses the plane by the exact signs, but its rounded distances to the plane
// both cancel to 0 (the normal's x, 1.4e-308, is lost beside 0.675), so t was 0 / 0.
// Within rounding of the plane, the hit is where the segment enters the triangle.
TEST(SegmentTriangleWatertight, SegmentWithinRoundingOfThePlaneHitsAtAFiniteT) {
  const Triangle tri{{5.0804629551391581e-299, 5.0804629551391581e-299, 5.0804629551391581e-299},
                     {-0.75, 0, 1.390679649680187e-308},
                     {0, -1, -1}};
  const Vector3 p(0.90039052967910604, 0.90039052967910604, 0.90039052967910604);
  const Vector3 q(-0.375, -0.5, -0.5);
  const TriangleHit h = IntersectSegmentTriangleWatertight(p, q, tri);
  ASSERT_TRUE(h.hit);
  EXPECT_TRUE(h.t >= 0 && h.t <= 1 && h.u >= 0 && h.v >= 0 && h.u + h.v <= 1) << h.t << " " << h.u << " " << h.v;
  EXPECT_LE(FindClosestPointOnTriangle(p + h.t * (q - p), tri).distance_squared, 1e-28);
}

// The same on random triangles: segments drawn in the plane (to rounding), so that the
// exact test sees a crossing (or not) that the rounded distances cannot place. Every
// hit's t, u, v are finite and in range, and the hit point is on the triangle to
// rounding, at its first point there (a little before t is off it).
TEST(SegmentTriangleWatertight, HitsWithinRoundingOfThePlaneStayInRange) {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> coordinate(-1, 1);
  const auto random_point = [&] { return Vector3(coordinate(rng), coordinate(rng), coordinate(rng)); };
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Triangle tri{random_point(), random_point(), random_point()};
    const auto in_plane = [&] {
      const double a = 1.5 * coordinate(rng), b = 1.5 * coordinate(rng);
      return Vector3(tri.v0 + a * (tri.v1 - tri.v0) + b * (tri.v2 - tri.v0));
    };
    const Vector3 p = in_plane();
    const Vector3 q = in_plane();
    const TriangleHit h = IntersectSegmentTriangleWatertight(p, q, tri);
    if (!h.hit) continue;
    ++hits;
    ASSERT_TRUE(h.t >= 0 && h.t <= 1 && h.u >= 0 && h.v >= 0 && h.u + h.v <= 1)
        << "case " << i << ": t " << h.t << " u " << h.u << " v " << h.v;
    EXPECT_LE(FindClosestPointOnTriangle(p + h.t * (q - p), tri).distance_squared, 1e-26) << "case " << i;
    if (h.t > 1e-6) {
      const Vector3 before = p + (h.t - 1e-6) * (q - p);
      EXPECT_GT(FindClosestPointOnTriangle(before, tri).distance_squared, 1e-26) << "case " << i;
    }
  }
  std::printf("hits within rounding of the plane: %d of 20000\n", hits);
  EXPECT_GT(hits, 1000);
}

// A ray from the plane and along it, both to rounding: the exact signs may still see a
// crossing, but never at an infinite or negative t.
TEST(RayTriangleWatertight, RaysParallelToRoundingHaveFiniteT) {
  std::mt19937_64 rng(78);
  std::uniform_real_distribution<double> coordinate(-1, 1);
  const auto random_point = [&] { return Vector3(coordinate(rng), coordinate(rng), coordinate(rng)); };
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Triangle tri{random_point(), random_point(), random_point()};
    const Vector3 origin = tri.v0 + 0.3 * (tri.v1 - tri.v0) + 0.3 * (tri.v2 - tri.v0);
    const Vector3 dir = 0.7 * (tri.v1 - tri.v0) - 0.2 * (tri.v2 - tri.v0);
    const TriangleHit h = IntersectRayTriangleWatertight(origin, dir, tri);
    hits += h.hit;
    if (h.hit) {
      ASSERT_TRUE(std::isfinite(h.t) && h.t >= 0) << "case " << i << ": t " << h.t;
    }
  }
  std::printf("rays along the plane to rounding that hit: %d of 20000\n", hits);
  EXPECT_GT(hits, 1000);
}

// ---------------------------------------------------------------------------------
// Random segments and rays against an oracle that solves [e1 e2 -d] (u v t) = p - v0
// with full-pivot LU, away from the boundary (margin 1e-9); the hit point must also
// lie on the triangle by the closest-point query.

struct Solved {
  double t, u, v;
  double margin;  // how far inside (> 0) or outside (< 0) the nearest boundary
};

Solved Solve(const Vector3& p, const Vector3& d, const Triangle& tri, bool is_ray) {
  Matrix3 m;
  m << tri.v1 - tri.v0, tri.v2 - tri.v0, -d;
  const Vector3 x = m.fullPivLu().solve(p - tri.v0);
  const double t_margin = is_ray ? x.z() : std::min(x.z(), 1 - x.z());
  return {x.z(), x.x(), x.y(), std::min({x.x(), x.y(), 1 - x.x() - x.y(), t_margin})};
}

TEST(SegmentTriangle, RandomCasesMatchLinearSolveOracle) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0, misses = 0;
  for (int n = 0; n < 100000; ++n) {
    const double scale = std::pow(10.0, static_cast<int>(rng() % 7) - 3);
    const Vector3 centre = Vector3(u(rng), u(rng), u(rng)) * 100 * scale;
    const auto point = [&] { return Vector3(centre + scale * Vector3(u(rng), u(rng), u(rng))); };
    const Triangle t{point(), point(), point()};
    const Vector3 p = point(), q = point();
    const bool is_ray = n % 2;
    const Vector3 d = is_ray ? Vector3((q - p) * (0.25 + u(rng) + 1)) : Vector3(q - p);
    const Solved s = Solve(p, d, t, is_ray);
    if (std::abs(s.margin) < 1e-9) continue;
    for (const Flavour& f : kFlavours) {
      const TriangleHit h = is_ray ? f.ray(p, d, t) : f.segment(p, q, t);
      ASSERT_EQ(h.hit, s.margin > 0) << f.name << " case " << n;
      if (!h.hit) continue;
      EXPECT_NEAR(h.t, s.t, 1e-9 * (is_ray ? 1 + std::abs(s.t) : 1)) << f.name << " case " << n;
      EXPECT_NEAR(h.u, s.u, 1e-9) << f.name << " case " << n;
      EXPECT_NEAR(h.v, s.v, 1e-9) << f.name << " case " << n;
      // the hit point lies on the triangle and is the barycentric point
      const Vector3 x = p + h.t * d;
      const Vector3 from_uv = (1 - h.u - h.v) * t.v0 + h.u * t.v1 + h.v * t.v2;
      EXPECT_LE((x - from_uv).norm(), 1e-9 * scale);
      EXPECT_LE(std::sqrt(FindClosestPointOnTriangle(x, t).distance_squared), 1e-9 * scale);
    }
    (s.margin > 0 ? hits : misses)++;
  }
  EXPECT_GT(hits, 5000);
  EXPECT_GT(misses, 5000);
}

// ---------------------------------------------------------------------------------
// Watertightness: segments aimed exactly through shared vertices and edge points of
// closed meshes. The watertight test must report every triangle that contains the
// aimed point (closed sets), so a segment can never slip through a crack; plain
// Möller-Trumbore is allowed to miss them all, and we count how often it does.

struct Mesh {
  std::vector<Vector3> vertices;
  std::vector<std::array<int, 3>> triangles;
};

// An octahedron (|x| + |y| + |z| = 1), midpoint-subdivided `levels` times, then each
// vertex moved by a random dyadic offset of up to `jitter` (multiples of 2^-30), so
// faces are no longer coplanar and every coordinate has a ~30-bit mantissa.
Mesh MakeJitteredOctahedron(int levels, double jitter, std::mt19937_64& rng) {
  Mesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoints;
    const auto midpoint = [&](int a, int b) {
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      const auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      m.vertices.push_back(0.5 * (m.vertices[a] + m.vertices[b]));
      return midpoints[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& [a, b, c] : m.triangles) {
      const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.push_back({a, ab, ca});
      next.push_back({ab, b, bc});
      next.push_back({ca, bc, c});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  const int64_t steps = static_cast<int64_t>(jitter * std::ldexp(1.0, 30));
  std::uniform_int_distribution<int64_t> offset(-steps, steps);
  for (Vector3& v : m.vertices) {
    for (int k = 0; k < 3; ++k) v[k] += std::ldexp(static_cast<double>(offset(rng)), -30);
  }
  return m;
}

Triangle TriangleOf(const Mesh& m, int i) {
  return {m.vertices[m.triangles[i][0]], m.vertices[m.triangles[i][1]],
          m.vertices[m.triangles[i][2]]};
}

struct AimStats {
  int aims = 0;
  int moller_trumbore_cracks = 0;  // aims where MT hit none of the triangles at the point
};

// Aims segments from random interior points through a vertex, or a dyadic point of an
// edge, and checks every triangle incident to it.
void AimThroughMesh(const Mesh& m, int count, std::mt19937_64& rng, AimStats& stats) {
  std::uniform_int_distribution<int64_t> interior(-100, 100);  // |p| < 0.1: inside
  for (int n = 0; n < count; ++n) {
    // pick a triangle, then a vertex of it or a point of one of its edges
    const int ti = static_cast<int>(rng() % m.triangles.size());
    const int corner = static_cast<int>(rng() % 3);
    const Vector3& a = m.vertices[m.triangles[ti][corner]];
    const Vector3& b = m.vertices[m.triangles[ti][(corner + 1) % 3]];
    const bool at_vertex = n % 3 == 0;
    const double lambda = at_vertex ? 0.0 : static_cast<double>(1 + rng() % 15) / 16;
    const Vector3 x = a + lambda * (b - a);  // exact: few-bit lambda, 30-bit coordinates
    const Vector3 p(std::ldexp(interior(rng), -10), std::ldexp(interior(rng), -10),
                    std::ldexp(interior(rng), -10));
    const Vector3 q = 2 * x - p;  // exact, so x = (p + q) / 2 lies on the segment
    ++stats.aims;
    bool mt_hit_any = false;
    int incident = 0;
    for (int k = 0; k < static_cast<int>(m.triangles.size()); ++k) {
      const Triangle t = TriangleOf(m, k);
      // incident: the aimed point lies in the closed triangle, up to a tiny tolerance
      // for the edge point (the point is exact; the test is only to find them)
      if (FindClosestPointOnTriangle(x, t).distance_squared > 1e-30) continue;
      ++incident;
      const TriangleHit w = IntersectSegmentTriangleWatertight(p, q, t);
      ASSERT_TRUE(w.hit) << "aim " << n << " missed incident triangle " << k;
      EXPECT_NEAR(w.t, 0.5, 1e-12);
      const Vector3 from_uv = (1 - w.u - w.v) * t.v0 + w.u * t.v1 + w.v * t.v2;
      EXPECT_LE((from_uv - x).norm(), 1e-12);
      mt_hit_any |= IntersectSegmentTriangle(p, q, t).hit;
    }
    EXPECT_GE(incident, at_vertex ? 3 : 2);
    stats.moller_trumbore_cracks += !mt_hit_any;
  }
}

TEST(SegmentTriangleWatertight, SegmentsThroughSharedVerticesAndEdgesOfClosedMeshes) {
  std::mt19937_64 rng(41);
  AimStats dyadic, jittered;
  AimThroughMesh(MakeJitteredOctahedron(2, 0, rng), 3000, rng, dyadic);
  AimThroughMesh(MakeJitteredOctahedron(2, 0.03, rng), 3000, rng, jittered);
  RecordProperty("mt_cracks_dyadic", dyadic.moller_trumbore_cracks);
  RecordProperty("mt_cracks_jittered", jittered.moller_trumbore_cracks);
  std::printf("Moller-Trumbore missed every incident triangle: %d of %d aims (exact "
              "octahedron), %d of %d (jittered)\n",
              dyadic.moller_trumbore_cracks, dyadic.aims, jittered.moller_trumbore_cracks,
              jittered.aims);
}

// Two triangles hinged on a shared edge with full-precision third vertices, and
// segments through a dyadic point of the edge with 50-bit offsets: the general
// floating-point case for Möller-Trumbore, exact for the watertight test.
TEST(SegmentTriangleWatertight, SegmentsThroughAGenericHinge) {
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int64_t> bits30(-(int64_t{1} << 29), int64_t{1} << 29);
  std::uniform_int_distribution<int64_t> bits50(-(int64_t{1} << 49), int64_t{1} << 49);
  int cracks = 0, both = 0;
  const int kAims = 20000;
  for (int n = 0; n < kAims; ++n) {
    const auto dyadic30 = [&] {
      return Vector3(std::ldexp(bits30(rng), -29), std::ldexp(bits30(rng), -29),
                     std::ldexp(bits30(rng), -29));
    };
    const Vector3 a = dyadic30(), b = dyadic30();
    const Vector3 c1(u(rng), u(rng), u(rng)), c2(u(rng), u(rng), u(rng));
    const Triangle t1{a, b, c1}, t2{b, a, c2};
    const Vector3 x = a + (static_cast<double>(1 + rng() % 15) / 16) * (b - a);
    const Vector3 delta(std::ldexp(bits50(rng), -50), std::ldexp(bits50(rng), -50),
                        std::ldexp(bits50(rng), -50));
    const Vector3 p = x + delta, q = x - delta;  // exact: x = (p + q) / 2
    const TriangleHit w1 = IntersectSegmentTriangleWatertight(p, q, t1);
    const TriangleHit w2 = IntersectSegmentTriangleWatertight(p, q, t2);
    ASSERT_TRUE(w1.hit) << "case " << n;
    ASSERT_TRUE(w2.hit) << "case " << n;
    const bool m1 = IntersectSegmentTriangle(p, q, t1).hit;
    const bool m2 = IntersectSegmentTriangle(p, q, t2).hit;
    cracks += !m1 && !m2;
    both += m1 && m2;
  }
  RecordProperty("mt_cracks_hinge", cracks);
  std::printf("Moller-Trumbore through a shared edge: missed both triangles %d of %d, hit "
              "both %d\n",
              cracks, kAims, both);
}

// ---------------------------------------------------------------------------------
// The filter: IntersectSegmentTriangleWatertight decides in floating point where its
// error bound allows and must give exactly the unfiltered test's answer everywhere,
// above all where the bound cannot decide: segments aimed exactly through vertices and
// edges (with coordinates whose products round), lying in the plane or ending on it,
// one rounding step beside an edge, and slivers, needles and tiny triangles.

void ExpectSameAsUnfiltered(const Vector3& p, const Vector3& q, const Triangle& t, int& hits,
                            const char* what, int n) {
  const TriangleHit got = IntersectSegmentTriangleWatertight(p, q, t);
  const TriangleHit want = IntersectSegmentTriangleWatertightUnfiltered(p, q, t);
  ASSERT_EQ(got.hit, want.hit) << what << " case " << n;
  hits += want.hit;
  if (!want.hit) return;
  // the same numbers, bit for bit
  EXPECT_EQ(got.t, want.t) << what << " case " << n;
  EXPECT_EQ(got.u, want.u) << what << " case " << n;
  EXPECT_EQ(got.v, want.v) << what << " case " << n;
}

TEST(SegmentTriangleWatertight, FilteredEqualsUnfiltered) {
  std::mt19937_64 rng(91);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int64_t> bits30(-(int64_t{1} << 29), int64_t{1} << 29);
  std::uniform_int_distribution<int64_t> bits50(-(int64_t{1} << 49), int64_t{1} << 49);
  const auto point = [&] { return Vector3(u(rng), u(rng), u(rng)); };
  const auto dyadic30 = [&] {
    return Vector3(std::ldexp(bits30(rng), -29), std::ldexp(bits30(rng), -29),
                   std::ldexp(bits30(rng), -29));
  };
  const auto offset50 = [&] {
    return Vector3(std::ldexp(bits50(rng), -50), std::ldexp(bits50(rng), -50),
                   std::ldexp(bits50(rng), -50));
  };
  const auto next_after = [](const Vector3& x, int axis, double towards) {
    Vector3 y = x;
    y[axis] = std::nextafter(y[axis], towards);
    return y;
  };
  const int kCases = 20000;
  int generic = 0, vertex = 0, edge = 0, beside = 0, in_plane = 0, on_plane = 0, slivers = 0;
  for (int n = 0; n < kCases; ++n) {
    // generic segments at scales 1e-6 .. 1e6, about a centre far from the origin
    const double scale = std::pow(10.0, static_cast<int>(rng() % 13) - 6);
    const Vector3 centre = 100 * scale * point();
    const Triangle t{centre + scale * point(), centre + scale * point(), centre + scale * point()};
    ExpectSameAsUnfiltered(centre + scale * point(), centre + scale * point(), t, generic, "generic", n);

    // through a vertex, and through a point of an edge (30-bit corners, 50-bit offsets:
    // the edge functions are exactly zero, their rounded values are not)
    const Vector3 a = dyadic30(), b = dyadic30();
    const Triangle hinge{a, b, point()};
    const Vector3 delta = offset50();
    ExpectSameAsUnfiltered(a + delta, a - delta, hinge, vertex, "vertex", n);
    const Vector3 x = a + (static_cast<double>(1 + rng() % 15) / 16) * (b - a);
    ExpectSameAsUnfiltered(x + delta, x - delta, hinge, edge, "edge", n);
    ExpectSameAsUnfiltered(x - delta, x + delta, {b, a, point()}, edge, "edge", n);
    // one rounding step beside the edge point, either way
    ExpectSameAsUnfiltered(next_after(x + delta, n % 3, 2), next_after(x - delta, n % 3, 2), hinge,
                           beside, "beside", n);
    ExpectSameAsUnfiltered(next_after(x + delta, n % 3, -2), x - delta, hinge, beside, "beside", n);

    // in the plane (dyadic weights of a dyadic triangle: exactly), and ending on it
    const Triangle flat{dyadic30(), dyadic30(), dyadic30()};
    const auto plane_point = [&](double alpha, double beta) {
      return Vector3(flat.v0 + alpha * (flat.v1 - flat.v0) + beta * (flat.v2 - flat.v0));
    };
    const auto weight = [&] { return static_cast<double>(static_cast<int>(rng() % 33) - 8) / 16; };
    ExpectSameAsUnfiltered(plane_point(weight(), weight()), plane_point(weight(), weight()), flat,
                           in_plane, "in plane", n);
    const Vector3 on = plane_point(weight(), weight());
    ExpectSameAsUnfiltered(on, on + delta + 0.25 * point(), flat, on_plane, "ending on the plane", n);
    ExpectSameAsUnfiltered(on + 0.25 * point(), on, flat, on_plane, "ending on the plane", n);
    // in the plane to rounding only (full-precision weights)
    const Vector3 near_p = flat.v0 + u(rng) * (flat.v1 - flat.v0) + u(rng) * (flat.v2 - flat.v0);
    const Vector3 near_q = flat.v0 + u(rng) * (flat.v1 - flat.v0) + u(rng) * (flat.v2 - flat.v0);
    ExpectSameAsUnfiltered(near_p, near_q, flat, in_plane, "in plane to rounding", n);

    // slivers (a corner within 1e-12 .. 1e-15 of the opposite edge), needles, tiny
    // triangles far from the origin
    const double thin = std::pow(10.0, -12 - static_cast<int>(rng() % 4));
    const Vector3 c = a + 0.5 * (b - a) + thin * point();
    const Triangle sliver{a, b, c};
    const Vector3 through = a + 0.375 * (b - a) + 0.5 * (c - a - 0.375 * (b - a));
    const Vector3 across = (b - a).cross(c - a).normalized() + 0.1 * point();
    ExpectSameAsUnfiltered(through + across, through - across, sliver, slivers, "sliver", n);
    const Triangle needle{a, a + thin * point(), b};
    ExpectSameAsUnfiltered(a + 0.5 * (b - a) + across, a + 0.5 * (b - a) - across, needle, slivers,
                           "needle", n);
    const Vector3 far = 1e3 * point();
    const Triangle tiny{far, far + 1e-9 * point(), far + 1e-9 * point()};
    ExpectSameAsUnfiltered(far + 1e-9 * point(), far + 1e-9 * point(), tiny, slivers, "tiny", n);
  }
  std::printf("hits: generic %d, vertex %d, edge %d, beside %d, in plane %d, on plane %d, thin %d\n",
              generic, vertex, edge, beside, in_plane, on_plane, slivers);
  // every kind has hits as well as misses
  for (int hits : {generic, vertex, edge, beside, in_plane, on_plane, slivers}) {
    EXPECT_GT(hits, 200);
    EXPECT_LT(hits, 2 * 3 * kCases - 200);
  }
}

// A hit's t is where the rounded plane distances cross, dp / (dp - dq), when they differ
// by more than their rounding 8 eps |n| (|p - v0| + |q - v0|); else where the segment,
// taken as in the plane, enters the triangle. The rule written out here (square roots
// and all) is the oracle for the test's shortcut that skips them, over segments whose
// distance difference is far above, near and below the rounding (tilts of 1e-17 to
// 1e-12 about the plane, at scales 1e-6 to 1e6).
TEST(SegmentTriangleWatertight, HitParameterFollowsTheRoundingRule) {
  const double eps = std::numeric_limits<double>::epsilon();
  auto entry_within_plane = [](const Vector3& p, const Vector3& q, const Triangle& tri, const Vector3& n) {
    const Vector3 d = q - p;
    double lo = 0, hi = 1;
    const Vector3* corners[3] = {&tri.v0, &tri.v1, &tri.v2};
    for (int i = 0; i < 3; ++i) {
      const Vector3& a = *corners[i];
      const Vector3 inward = n.cross(*corners[(i + 1) % 3] - a);
      const double start = inward.dot(p - a);
      const double rate = inward.dot(d);
      if (rate > 0) lo = std::max(lo, -start / rate);
      if (rate < 0) hi = std::min(hi, -start / rate);
    }
    return lo <= hi ? lo : std::clamp(0.5 * (lo + hi), 0.0, 1.0);
  };
  std::mt19937_64 rng(93);
  std::uniform_real_distribution<double> u(-1, 1), unit(0, 1);
  int clear = 0, within = 0;
  for (int k = 0; k < 40000; ++k) {
    const double scale = std::pow(10.0, static_cast<int>(rng() % 13) - 6);
    const Vector3 centre = 10 * scale * Vector3(u(rng), u(rng), u(rng));
    const Triangle tri{centre + scale * Vector3(u(rng), u(rng), u(rng)),
                       centre + scale * Vector3(u(rng), u(rng), u(rng)),
                       centre + scale * Vector3(u(rng), u(rng), u(rng))};
    const Vector3 n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
    const Vector3 unit_n = n.normalized();
    // two points over the triangle's plane, tilted across it by 1e-17 .. 1e-12 of the
    // scale (or by a fraction of it: generic crossings)
    const auto in_plane = [&] {
      const double a = 1.5 * unit(rng) - 0.25, b = 1.5 * unit(rng) - 0.25;
      return Vector3(tri.v0 + a * (tri.v1 - tri.v0) + b * (tri.v2 - tri.v0));
    };
    const double tilt = scale * (k % 4 == 0 ? 0.3 : std::pow(10.0, -17 + 5 * unit(rng)));
    const Vector3 p = in_plane() + tilt * unit(rng) * unit_n;
    const Vector3 q = in_plane() - tilt * unit(rng) * unit_n;
    if (p == q) continue;
    const TriangleHit hit = IntersectSegmentTriangleWatertight(p, q, tri);
    if (!hit.hit || Orient3d(tri.v0, tri.v1, tri.v2, p) == 0 || Orient3d(tri.v0, tri.v1, tri.v2, q) == 0) continue;
    const double dp = n.dot(p - tri.v0), dq = n.dot(q - tri.v0);
    const double rounding = 8 * eps * n.norm() * ((p - tri.v0).norm() + (q - tri.v0).norm());
    if (std::abs(dp - dq) > rounding) {
      ++clear;
      ASSERT_EQ(hit.t, std::clamp(dp / (dp - dq), 0.0, 1.0)) << k;
    } else {
      ++within;
      ASSERT_EQ(hit.t, entry_within_plane(p, q, tri, n)) << k;
    }
  }
  std::printf("hits: crossing clear of the rounding %d, within it %d\n", clear, within);
  EXPECT_GT(clear, 2000);
  EXPECT_GT(within, 200);
}

TEST(SegmentTriangleWatertight, FilteredNonFiniteInputIsAMiss) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {nan, inf, -inf}) {
    for (int k = 0; k < 15; ++k) {
      Vector3 p(1, 1, 1), q(1, 1, -1);
      Triangle t = kTri;
      Vector3* slots[5] = {&p, &q, &t.v0, &t.v1, &t.v2};
      (*slots[k / 3])[k % 3] = bad;
      EXPECT_FALSE(IntersectSegmentTriangleWatertight(p, q, t).hit) << bad << " at " << k;
    }
  }
}

}  // namespace
}  // namespace hapticd::geometry
