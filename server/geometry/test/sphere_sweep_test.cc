#include "server/geometry/sphere_sweep.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/test/random_geometry.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/segment_triangle.h"

namespace hapticd::geometry {
namespace {

using Indices = TriangleMesh::TriangleIndices;
using Feature = TriangleFeature;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// A right triangle in the plane z = 0, its normal +z, legs of 4 along x and y.
const Triangle kFloor{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};
const Vector3 kUp = Vector3::UnitZ();

std::shared_ptr<const TriangleMesh> Share(TriangleMesh mesh) {
  return std::make_shared<const TriangleMesh>(std::move(mesh));
}

Vector3 At(const Vector3& a, const Vector3& b, double t) { return a + t * (b - a); }

double DistanceTo(const Triangle& tri, const Vector3& c) {
  return std::sqrt(FindClosestPointOnTriangle(c, tri).distance_squared);
}

double DistanceTo(const TriangleMesh& mesh, const Vector3& c) {
  double best = kInf;
  for (int t : mesh.nondegenerate_triangles()) {
    best = std::min(best, DistanceTo(mesh.triangle(t), c));
  }
  return best;
}

Vector3 RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Vector3(normal(rng), normal(rng), normal(rng)).normalized();
}

void ExpectHit(const SphereSweepHit& hit, double t, const Vector3& point, const Vector3& normal,
               Feature feature, double tolerance = 0) {
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.t, t, tolerance);
  EXPECT_NEAR((hit.point - point).norm(), 0, tolerance) << hit.point.transpose();
  EXPECT_NEAR((hit.normal - normal).norm(), 0, tolerance) << hit.normal.transpose();
  EXPECT_EQ(hit.feature, feature);
  EXPECT_EQ(hit.triangle, -1);
}

// ---------------------------------------------------------------------------------
// Hand-built first contacts of a sphere (dyadic, so most answers are exact).

TEST(SphereSweep, FirstContactWithTheFace) {
  // falling straight down onto the face: touches when the centre is 1 above it
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, 3}, {1, 1, -1}, 1), 0.5, {1, 1, 0}, kUp,
            Feature::kFace);
  // from below: the normal turns to the centre's side
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, -3}, {1, 1, 1}, 1), 0.5, {1, 1, 0}, -kUp,
            Feature::kFace);
  // obliquely: the centre reaches height 1 at t = 0.5, above (1.5, 1.25)
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, 2}, {2, 1.5, 0}, 1), 0.5, {1.5, 1.25, 0}, kUp,
            Feature::kFace);
}

TEST(SphereSweep, FirstContactWithAnEdge) {
  // sideways in the plane onto edge 01 (the x axis)
  ExpectHit(SweepSphereTriangle(kFloor, {2, -3, 0}, {2, 1, 0}, 1), 0.5, {2, 0, 0},
            -Vector3::UnitY(), Feature::kEdge01);
  // at an angle, landing with the centre at (2, -0.6, 0.8), 1 from the edge
  const Vector3 dir(0, 0.6, -0.8);
  const SphereSweepHit hit = SweepSphereTriangle(kFloor, Vector3(2, -0.6, 0.8) - 3 * dir,
                                                 Vector3(2, -0.6, 0.8) + 3 * dir, 1);
  ExpectHit(hit, 0.5, {2, 0, 0}, {0, -0.6, 0.8}, Feature::kEdge01, 1e-15);
  // onto the hypotenuse (edge 12, the line x + y = 4) from outside, along its normal:
  // 1/sqrt(2) from it when the centre is at (2.5, 2.5)
  ExpectHit(SweepSphereTriangle(kFloor, {3, 3, 0}, {1, 1, 0}, std::sqrt(0.5)), 0.25, {2, 2, 0},
            Vector3(1, 1, 0).normalized(), Feature::kEdge12, 1e-15);
}

TEST(SphereSweep, FirstContactWithAVertex) {
  // along the x axis towards v0: the edge's own line, so only v0's sphere is met
  ExpectHit(SweepSphereTriangle(kFloor, {-3, 0, 0}, {1, 0, 0}, 1), 0.5, {0, 0, 0},
            -Vector3::UnitX(), Feature::kVertex0);
  // from v0's corner region, landing 1 from v0 at (-0.6, -0.8, 0)
  ExpectHit(SweepSphereTriangle(kFloor, {-1.8, -2.4, 0}, {0.6, 0.8, 0}, 1), 0.5, {0, 0, 0},
            {-0.6, -0.8, 0}, Feature::kVertex0, 1e-15);
  // straight down onto v1 and v2
  ExpectHit(SweepSphereTriangle(kFloor, {4, 0, 3}, {4, 0, -1}, 1), 0.5, {4, 0, 0}, kUp,
            Feature::kVertex1);
  ExpectHit(SweepSphereTriangle(kFloor, {0, 4, 3}, {0, 4, -1}, 1), 0.5, {0, 4, 0}, kUp,
            Feature::kVertex2);
  // beyond v1 along the x axis, coming back: v1's sphere
  ExpectHit(SweepSphereTriangle(kFloor, {7, 0, 0}, {3, 0, 0}, 1), 0.5, {4, 0, 0}, Vector3::UnitX(),
            Feature::kVertex1);
}

TEST(SphereSweep, MissesWhatItPassesBy) {
  // beside the triangle, farther than r
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {-2, -2, 3}, {-2, -2, -3}, 1).hit);
  // stops short of it
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, 3}, {1, 1, 1.5}, 1).hit);
  // moving away
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, 2}, {1, 1, 5}, 1).hit);
  // ends exactly touching: D(1) = r, never below r - skin
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, 3}, {1, 1, 1}, 1).hit);
}

// ---------------------------------------------------------------------------------
// What touches at the start.

TEST(SphereSweep, TouchingAFaceBlocksOnlyMotionIntoIt) {
  const Vector3 a(1, 1, 1);  // resting on the face, D = r = 1
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, 1.5, 1}, 1).hit) << "tangential";
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, 1.5, 1.5}, 1).hit) << "away";
  ExpectHit(SweepSphereTriangle(kFloor, a, {2, 1.5, 0.5}, 1), 0, {1, 1, 0}, kUp, Feature::kFace);
  // going in by less than the skin does not block; by more, it does at once
  const double skin = CalcSphereSweepSkin(a, {2, 1, 1}, 1);
  EXPECT_DOUBLE_EQ(skin, 1e-9 * (1 + 2));
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, 1, 1 - 0.5 * skin}, 1).hit);
  EXPECT_TRUE(SweepSphereTriangle(kFloor, a, {2, 1, 1 - 2 * skin}, 1).hit);
}

TEST(SphereSweep, OverlappingAFaceBlocksOnlyMotionIntoIt) {
  const Vector3 a(1, 1, 0.5);  // half a radius deep
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {3, 0.5, 0.5}, 1).hit) << "tangential";
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {1, 1, 0.75}, 1).hit) << "away";
  ExpectHit(SweepSphereTriangle(kFloor, a, {1, 1, 0.25}, 1), 0, {1, 1, 0}, kUp, Feature::kFace);
  // centre below the face: out is down, so going up is going in
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, -0.5}, {1, 1, -1}, 1).hit);
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, -0.5}, {1, 1, 0}, 1), 0, {1, 1, 0}, -kUp,
            Feature::kFace);
}

TEST(SphereSweep, CentreOnTheFaceCountsAsItsFrontSide) {
  const Vector3 a(1, 1, 0);
  ExpectHit(SweepSphereTriangle(kFloor, a, {1, 1, -1}, 1), 0, a, kUp, Feature::kFace);
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {1, 1, 1}, 1).hit);
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, 1, 0}, 1).hit) << "in the plane";
}

TEST(SphereSweep, TouchingAnEdgeBlocksOnlyMotionIntoIt) {
  const Vector3 a(2, -1, 0);  // 1 from edge 01, in the plane
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {3, -1, 0}, 1).hit) << "along the edge";
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, -1.5, 0.5}, 1).hit) << "away";
  ExpectHit(SweepSphereTriangle(kFloor, a, {2, 0, 0}, 1), 0, {2, 0, 0}, -Vector3::UnitY(),
            Feature::kEdge01);
  // straight up: tangent to the edge's cylinder
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {2, -1, 1}, 1).hit);
}

TEST(SphereSweep, GrazingShallowerThanTheSkinDoesNotBlock) {
  // passing over edge 01 onto the face at height h: D falls to h, then stays there
  const double r = 1;
  const double skin = CalcSphereSweepSkin({2, -3, 1}, {2, 3, 1}, r);
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {2, -3, 1}, {2, 3, 1}, r).hit) << "at r";
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {2, -3, 1 - 0.5 * skin}, {2, 3, 1 - 0.5 * skin}, r).hit);
  // deeper than the skin: blocks where D first reaches r, on the edge's cylinder
  const double h = 1 - 4 * skin;
  const SphereSweepHit hit = SweepSphereTriangle(kFloor, {2, -3, h}, {2, 3, h}, r);
  ASSERT_TRUE(hit.hit);
  const double y = -std::sqrt(1 - h * h);
  EXPECT_NEAR(hit.t, (y + 3) / 6, 1e-12);
  EXPECT_EQ(hit.feature, Feature::kEdge01);
  EXPECT_NEAR(DistanceTo(kFloor, At({2, -3, h}, {2, 3, h}, hit.t)), r, 1e-12);
}

// ---------------------------------------------------------------------------------
// A point (r = 0): the watertight segment test.

TEST(SphereSweep, PointCrossingsAreExact) {
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, 1}, {1, 1, -1}, 0), 0.5, {1, 1, 0}, kUp,
            Feature::kFace);
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, -1}, {1, 1, 3}, 0), 0.25, {1, 1, 0}, -kUp,
            Feature::kFace);
  ExpectHit(SweepSphereTriangle(kFloor, {2, 0, 1}, {2, 0, -1}, 0), 0.5, {2, 0, 0}, kUp,
            Feature::kEdge01);
  ExpectHit(SweepSphereTriangle(kFloor, {2, 2, 1}, {2, 2, -1}, 0), 0.5, {2, 2, 0}, kUp,
            Feature::kEdge12);
  ExpectHit(SweepSphereTriangle(kFloor, {0, 2, 1}, {0, 2, -1}, 0), 0.5, {0, 2, 0}, kUp,
            Feature::kEdge20);
  ExpectHit(SweepSphereTriangle(kFloor, {1, -1, 1}, {-1, 1, -1}, 0), 0.5, {0, 0, 0}, kUp,
            Feature::kVertex0);
  ExpectHit(SweepSphereTriangle(kFloor, {4, 0, 1}, {4, 0, -1}, 0), 0.5, {4, 0, 0}, kUp,
            Feature::kVertex1);
  ExpectHit(SweepSphereTriangle(kFloor, {0, 4, 1}, {0, 4, -1}, 0), 0.5, {0, 4, 0}, kUp,
            Feature::kVertex2);
  // ending on the face: touching counts, the point is b exactly
  ExpectHit(SweepSphereTriangle(kFloor, {1, 1, 3}, {1, 1, 0}, 0), 1, {1, 1, 0}, kUp,
            Feature::kFace);
  // just beside an edge
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {2, -0x1p-40, 1}, {2, -0x1p-40, -1}, 0).hit);
}

TEST(SphereSweep, PointOnTheFaceBlocksOnlyMotionBehindIt) {
  for (const Vector3& a : {Vector3(1, 1, 0), Vector3(2, 0, 0), Vector3(0, 0, 0)}) {
    SCOPED_TRACE(a.transpose());
    ExpectHit(SweepSphereTriangle(kFloor, a, {1, 0.5, -1}, 0), 0, a, kUp,
              a == Vector3(1, 1, 0) ? Feature::kFace
                                    : (a.x() == 0 ? Feature::kVertex0 : Feature::kEdge01));
    EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {1, 0.5, 1}, 0).hit) << "away";
    EXPECT_FALSE(SweepSphereTriangle(kFloor, a, {1, 0.5, 0}, 0).hit) << "in the plane";
  }
}

TEST(SphereSweep, RadiusLostInRoundingIsSweptAsAPoint) {
  const Vector3 a(1, 1, 1), b(1, 1, -1);
  const SphereSweepHit point = SweepSphereTriangle(kFloor, a, b, 0);
  const SphereSweepHit tiny = SweepSphereTriangle(kFloor, a, b, 1e-14);
  ASSERT_TRUE(tiny.hit);
  EXPECT_EQ(tiny.t, point.t);
  EXPECT_EQ(tiny.normal, point.normal);
  EXPECT_EQ(CalcSphereSweepSkin(a, b, 1e-14), 0);
  // a small radius well above the rounding is a sphere, with half of it as skin at most
  EXPECT_EQ(CalcSphereSweepSkin(a, b, 1e-11), 0.5e-11);
  EXPECT_LT(SweepSphereTriangle(kFloor, a, b, 1e-6).t, 0.5);
}

// ---------------------------------------------------------------------------------
// Bad input.

TEST(SphereSweep, NonFiniteNegativeOrMotionlessInputMisses) {
  const Vector3 a(1, 1, 3), b(1, 1, -1);
  ASSERT_TRUE(SweepSphereTriangle(kFloor, a, b, 1).hit);
  for (double bad : {kNan, kInf, -kInf}) {
    for (int i = 0; i < 3; ++i) {
      Vector3 a_bad = a, b_bad = b;
      a_bad[i] = bad;
      b_bad[i] = bad;
      EXPECT_FALSE(SweepSphereTriangle(kFloor, a_bad, b, 1).hit);
      EXPECT_FALSE(SweepSphereTriangle(kFloor, a, b_bad, 0).hit);
      Triangle tri = kFloor;
      tri.v1[i] = bad;
      EXPECT_FALSE(SweepSphereTriangle(tri, a, b, 1).hit);
      EXPECT_FALSE(SweepSphereTriangle(tri, a, b, 0).hit);
    }
    EXPECT_FALSE(SweepSphereTriangle(kFloor, a, b, bad).hit);
    EXPECT_EQ(CalcSphereSweepSkin(a, b, bad), 0);
  }
  EXPECT_FALSE(SweepSphereTriangle(kFloor, a, b, -1).hit);
  // no motion: not even a sphere sunk into the face is blocked
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, 0.5}, {1, 1, 0.5}, 1).hit);
  EXPECT_FALSE(SweepSphereTriangle(kFloor, {1, 1, 0}, {1, 1, 0}, 0).hit);
}

TEST(SphereSweep, DegenerateTriangleHasEdgesAndCornersButNoFace) {
  const Triangle needle{{0, 0, 0}, {2, 0, 0}, {4, 0, 0}};
  const SphereSweepHit hit = SweepSphereTriangle(needle, {1, 0, 3}, {1, 0, -1}, 1);
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 0.5);
  EXPECT_NEAR((hit.normal - kUp).norm(), 0, 1e-15);
  EXPECT_FALSE(SweepSphereTriangle(needle, {1, 0, 3}, {1, 0, -1}, 0).hit);
}

// ---------------------------------------------------------------------------------
// Random sweeps against an independent oracle: D(t), the distance from the centre to the
// triangle by FindClosestPointOnTriangle. D is convex in t, so a golden-section search
// finds its minimum, and bisection before the minimum where it first reaches r.

enum class Verdict { kHit, kMiss, kUnsure };

struct OracleAnswer {
  Verdict verdict = Verdict::kUnsure;
  double t = 0;
};

OracleAnswer SweepOracle(const Triangle& tri, const Vector3& a, const Vector3& b, double r) {
  const auto D = [&](double t) { return DistanceTo(tri, At(a, b, t)); };
  // decisions within this of a threshold are left unchecked
  constexpr double kBand = 1e-10;
  double lo = 0, hi = 1;
  const double phi = (std::sqrt(5.0) - 1) / 2;
  for (int i = 0; i < 80; ++i) {
    const double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
    if (D(x1) <= D(x2)) hi = x2; else lo = x1;
  }
  double t_min = 0.5 * (lo + hi);
  for (double t : {0.0, 1.0}) if (D(t) < D(t_min)) t_min = t;
  const double d_min = D(t_min), d0 = D(0);
  const double block = r - CalcSphereSweepSkin(a, b, r);
  if (std::abs(d0 - block) < kBand) return {};
  if (d0 < block) {
    // deeper than the skin at the start: blocked at once when D decreases
    if (d_min < d0 - kBand) return {Verdict::kHit, 0};
    if (d_min >= d0 - 1e-14) return {Verdict::kMiss, 0};
    return {};
  }
  if (d_min > block + kBand) return {Verdict::kMiss, 0};
  if (d_min > block - kBand) return {};
  if (d0 <= r) return {Verdict::kHit, 0};
  double before = 0, after = t_min;
  for (int i = 0; i < 200 && after - before > 1e-17; ++i) {
    const double mid = 0.5 * (before + after);
    (D(mid) > r ? before : after) = mid;
  }
  return {Verdict::kHit, after};
}

// A random triangle in [-1, 1]^3 and a sweep near it, half of them aimed at a point of
// the triangle (a quarter of those at an edge, an eighth at a corner).
struct SweepCase {
  Triangle tri;
  Vector3 a, b;
  double r;
};

SweepCase RandomSweepCase(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1), cube(-1, 1);
  SweepCase c;
  c.tri = {{cube(rng), cube(rng), cube(rng)}, {cube(rng), cube(rng), cube(rng)},
           {cube(rng), cube(rng), cube(rng)}};
  c.r = 0.02 + 0.5 * unit(rng);
  double u = unit(rng), v = unit(rng);
  if (u + v > 1) u = 1 - u, v = 1 - v;
  const int kind = static_cast<int>(8 * unit(rng));
  if (kind == 0) u = v = 0;
  if (kind == 1) v = 1 - u;
  if (kind == 2) v = 0;
  const Vector3 target = c.tri.v0 + u * (c.tri.v1 - c.tri.v0) + v * (c.tri.v2 - c.tri.v0);
  const Vector3 from = RandomUnit(rng);
  c.a = target + (1.5 * c.r + 0.5) * unit(rng) * from;
  if (unit(rng) < 0.5) {
    c.b = target - from * unit(rng) + 0.3 * c.r * unit(rng) * RandomUnit(rng);
  } else {
    c.b = c.a + 2 * unit(rng) * RandomUnit(rng);
  }
  return c;
}

struct OracleTally {
  int hits = 0, at_start = 0, misses = 0, unsure = 0;
};

// Checks one sweep against the oracle: the decision, t, the contact, and that the centre
// is r from the triangle at t (t > 0) and farther before.
void CheckAgainstOracle(const SweepCase& c, const std::string& what, OracleTally& tally) {
  const OracleAnswer want = SweepOracle(c.tri, c.a, c.b, c.r);
  const SphereSweepHit got = SweepSphereTriangle(c.tri, c.a, c.b, c.r);
  if (want.verdict == Verdict::kUnsure) {
    ++tally.unsure;
    return;
  }
  ASSERT_EQ(got.hit, want.verdict == Verdict::kHit) << what;
  if (!got.hit) {
    ++tally.misses;
    return;
  }
  ++tally.hits;
  tally.at_start += got.t == 0;
  ASSERT_NEAR(got.t, want.t, 1e-7) << what;
  // the contact: the closest point of the triangle, and the unit normal towards the centre
  const Vector3 centre = At(c.a, c.b, got.t);
  const ClosestPointOnTriangle closest = FindClosestPointOnTriangle(centre, c.tri);
  EXPECT_NEAR((got.point - closest.point).norm(), 0, 1e-12) << what;
  EXPECT_NEAR(got.normal.norm(), 1, 1e-14) << what;
  const double distance = std::sqrt(closest.distance_squared);
  EXPECT_NEAR((got.normal - (centre - closest.point) / distance).norm(), 0, 1e-9) << what;
  if (got.t == 0) {
    EXPECT_LT((c.b - c.a).dot(got.normal), 0) << what << ": blocked at the start moving out";
    return;
  }
  // at t the distance is r; before t it is more
  EXPECT_NEAR(distance, c.r, 1e-9 * c.r) << what;
  for (int i = 0; i < 32; ++i) {
    EXPECT_GT(DistanceTo(c.tri, At(c.a, c.b, got.t * i / 32)), c.r * (1 - 1e-12)) << what;
  }
}

TEST(SphereSweep, RandomSweepsMatchTheDistanceOracle) {
  std::mt19937_64 rng(301);
  OracleTally tally;
  for (int k = 0; k < 6000; ++k) {
    CheckAgainstOracle(RandomSweepCase(rng), "case " + std::to_string(k), tally);
    if (HasFatalFailure()) return;
  }
  // the cases cover hits at and after the start, and misses
  EXPECT_GT(tally.hits - tally.at_start, 1000);
  EXPECT_GT(tally.at_start, 1000);
  EXPECT_GT(tally.misses, 1000);
  EXPECT_LT(tally.unsure, 20);
}

// A sphere resting on a triangle (its centre r from a point of a face, an edge or a
// corner, in that feature's normal cone, rounded), moving anywhere, a quarter of the time
// tangentially: blocked exactly when the motion takes it in by more than the skin.
TEST(SphereSweep, RandomSweepsFromRestMatchTheDistanceOracle) {
  std::mt19937_64 rng(309);
  std::uniform_real_distribution<double> unit(0, 1);
  OracleTally tally;
  int tangential = 0;
  for (int k = 0; k < 9000; ++k) {
    SweepCase c = RandomSweepCase(rng);
    const Triangle& tri = c.tri;
    const Vector3 n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalized();
    Vector3 rest, out;
    if (k % 3 == 0) {
      // on the face, either side
      const double u = 0.05 + 0.45 * unit(rng), v = 0.05 + 0.45 * unit(rng);
      rest = tri.v0 + u * (tri.v1 - tri.v0) + v * (tri.v2 - tri.v0);
      out = k % 2 == 0 ? n : Vector3(-n);
    } else if (k % 3 == 1) {
      // on edge 01, out between its outward side and either face side
      rest = tri.v0 + (0.05 + 0.9 * unit(rng)) * (tri.v1 - tri.v0);
      const Vector3 side = (tri.v1 - tri.v0).cross(n).normalized();
      const double angle = 0.95 * std::numbers::pi * (unit(rng) - 0.5);
      out = std::cos(angle) * side + std::sin(angle) * n;
    } else {
      // on corner v0, out where both of its edges lead away
      rest = tri.v0;
      do out = RandomUnit(rng);
      while (out.dot(tri.v1 - tri.v0) > 0 || out.dot(tri.v2 - tri.v0) > 0);
    }
    c.a = rest + c.r * out;
    Vector3 d = RandomUnit(rng);
    if (k % 4 == 1) {
      d -= d.dot(out) * out;
      ++tangential;
    }
    c.b = c.a + unit(rng) * d;
    CheckAgainstOracle(c, "case " + std::to_string(k), tally);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(tally.hits, 3000);
  EXPECT_GT(tally.at_start, 2000);
  EXPECT_GT(tally.misses, tangential + 2500);
  EXPECT_LT(tally.unsure, 20);
}

TEST(SphereSweep, RandomPointSweepsMatchTheSegmentTest) {
  std::mt19937_64 rng(302);
  int hits = 0;
  for (int k = 0; k < 4000; ++k) {
    const SweepCase c = RandomSweepCase(rng);
    const SphereSweepHit got = SweepSphereTriangle(c.tri, c.a, c.b, 0);
    // Moller-Trumbore: another algorithm; random inputs stay clear of edges and planes
    const TriangleHit want = IntersectSegmentTriangle(c.a, c.b, c.tri);
    ASSERT_EQ(got.hit, want.hit) << k;
    if (!got.hit) continue;
    ++hits;
    EXPECT_NEAR(got.t, want.t, 1e-12) << k;
    EXPECT_NEAR(DistanceTo(c.tri, got.point), 0, 1e-12) << k;
    const Vector3 n = (c.tri.v1 - c.tri.v0).cross(c.tri.v2 - c.tri.v0).normalized();
    EXPECT_NEAR((got.normal - (n.dot(c.a - c.tri.v0) > 0 ? n : Vector3(-n))).norm(), 0, 1e-15);
  }
  EXPECT_GT(hits, 1000);
}

// ---------------------------------------------------------------------------------
// Meshes.

// Every non-degenerate triangle, no BVH.
SphereSweepHit BruteSweep(const TriangleMesh& mesh, const Vector3& a, const Vector3& b, double r) {
  SphereSweepHit best;
  for (int t : mesh.nondegenerate_triangles()) {
    SphereSweepHit h = SweepSphereTriangle(mesh.triangle(t), a, b, r);
    if (h.hit && (!best.hit || h.t < best.t)) {
      best = h;
      best.triangle = t;
    }
  }
  return best;
}

// A random point of the mesh's surface, moved off it along the normal by `offset`.
Vector3 NearSurface(const TriangleMesh& mesh, double offset, std::mt19937_64& rng) {
  const std::vector<int>& ids = mesh.nondegenerate_triangles();
  std::uniform_int_distribution<size_t> pick(0, ids.size() - 1);
  std::uniform_real_distribution<double> unit(0, 1);
  const int t = ids[pick(rng)];
  const Triangle tri = mesh.triangle(t);
  double u = unit(rng), v = unit(rng);
  if (u + v > 1) u = 1 - u, v = 1 - v;
  return tri.v0 + u * (tri.v1 - tri.v0) + v * (tri.v2 - tri.v0) + offset * mesh.face_normal(t);
}

TEST(SphereSweepMesh, MatchesBruteForceOverTheTriangles) {
  std::mt19937_64 rng(303);
  std::uniform_real_distribution<double> unit(0, 1), signed_unit(-1, 1);
  const std::vector<std::shared_ptr<const TriangleMesh>> meshes = {
      Share(MakeIcosphere(7, 1.0)), Share(MakeTorus(1.0, 0.35, 28, 14)),
      Share(MakeBoxMesh({0.5, 1, 0.75}, 5)), Share(MakeRandomSoup(rng, 400, 0.15, 13, 5))};
  int hits = 0, at_start = 0;
  for (const auto& mesh : meshes) {
    const MeshBvh bvh(mesh);
    const double size = mesh->size();
    for (int k = 0; k < 800; ++k) {
      const double r = std::array<double, 4>{0, 1e-15 * size, 0.01 * size, 0.05 * size}[k % 4];
      const Vector3 a = NearSurface(*mesh, (0.06 * signed_unit(rng)) * size, rng);
      const Vector3 b = a + (k % 8 < 6 ? 0.05 : 1.0) * size * unit(rng) * RandomUnit(rng);
      const std::string what = "mesh of " + std::to_string(mesh->num_triangles()) +
                               ", sweep " + std::to_string(k);
      const SphereSweepHit got = SweepSphereMesh(bvh, a, b, r);
      const SphereSweepHit want = BruteSweep(*mesh, a, b, r);
      ASSERT_EQ(got.hit, want.hit) << what;
      if (!got.hit) continue;
      ++hits;
      at_start += got.t == 0;
      // the same first t, bit for bit; the triangle may be another one touched then
      EXPECT_EQ(got.t, want.t) << what;
      SphereSweepHit again = SweepSphereTriangle(mesh->triangle(got.triangle), a, b, r);
      ASSERT_TRUE(again.hit) << what;
      EXPECT_EQ(again.t, got.t) << what;
      EXPECT_EQ(again.point, got.point) << what;
      EXPECT_EQ(again.normal, got.normal) << what;
      EXPECT_EQ(again.feature, got.feature) << what;
    }
  }
  EXPECT_GT(hits, 800);
  EXPECT_GT(at_start, 50);
}

TEST(SphereSweepMesh, PointSweepsMatchFindFirstSegmentHit) {
  // where no sweep starts on a triangle's plane, r = 0 is FindFirstSegmentHit exactly
  std::mt19937_64 rng(304);
  const auto mesh = Share(MakeTorus(1.0, 0.35, 40, 20));
  const MeshBvh bvh(mesh);
  int hits = 0;
  for (int k = 0; k < 3000; ++k) {
    const Vector3 a = NearSurface(*mesh, 0.1 * (2 * (k % 2) - 1), rng);
    const Vector3 b = a + 0.3 * RandomUnit(rng);
    const SphereSweepHit got = SweepSphereMesh(bvh, a, b, 0);
    const SegmentMeshHit want = FindFirstSegmentHit(bvh, a, b);
    ASSERT_EQ(got.hit, want.hit) << k;
    if (!got.hit) continue;
    ++hits;
    EXPECT_EQ(got.t, want.t) << k;
  }
  EXPECT_GT(hits, 1000);
}

TEST(SphereSweepMesh, SpheresStopAtDistanceRAndNeverEnterTheMesh) {
  std::mt19937_64 rng(305);
  std::uniform_real_distribution<double> unit(0, 1);
  const auto mesh = Share(MakeIcosphere(6, 1.0));
  const MeshBvh bvh(mesh);
  int hits = 0;
  for (int k = 0; k < 300; ++k) {
    const double r = 0.02 + 0.1 * unit(rng);
    // from outside, at least r off the surface, to anywhere inside
    const Vector3 a = NearSurface(*mesh, r + 0.2 * unit(rng), rng);
    if (DistanceTo(*mesh, a) <= r) continue;
    const Vector3 b = 0.9 * NearSurface(*mesh, 0, rng);
    const SphereSweepHit hit = SweepSphereMesh(bvh, a, b, r);
    ASSERT_TRUE(hit.hit) << k;
    ++hits;
    const double skin = CalcSphereSweepSkin(a, b, r);
    EXPECT_NEAR(DistanceTo(*mesh, At(a, b, hit.t)), r, 1e-9 * r) << k;
    for (int i = 0; i < 16; ++i) {
      EXPECT_GT(DistanceTo(*mesh, At(a, b, hit.t * i / 16)), r - skin) << k;
    }
    // the point sweep crosses the surface no earlier
    const SphereSweepHit point = SweepSphereMesh(bvh, a, b, 0);
    ASSERT_TRUE(point.hit) << k;
    EXPECT_LE(hit.t, point.t) << k;
  }
  EXPECT_GT(hits, 250);
}

// The top face of a box made of 8 x 8 squares, two triangles each: a sphere resting on it
// (at height r, within rounding) slides across its edges and vertices freely, and is
// stopped at once when it moves into it.
TEST(SphereSweepMesh, SlidingOnAFlatFaceOfManyTrianglesIsNeverBlocked) {
  const auto mesh = Share(MakeBoxMesh({1, 1, 1}, 8));
  const MeshBvh bvh(mesh);
  // exact: r = 1/4 at height 5/4, along grid lines and diagonals through the vertices
  const double r = 0.25;
  for (double z : {1.25, std::nextafter(1.25, 0.0), std::nextafter(1.25, 2.0)}) {
    for (double y : {0.0, 0.25, -0.5, 0.125}) {
      EXPECT_FALSE(SweepSphereMesh(bvh, {-0.875, y, z}, {0.875, y, z}, r).hit) << y << " " << z;
      EXPECT_FALSE(SweepSphereMesh(bvh, {y, -0.875, z}, {y, 0.875, z}, r).hit) << y << " " << z;
    }
    EXPECT_FALSE(SweepSphereMesh(bvh, {-0.75, -0.75, z}, {0.75, 0.75, z}, r).hit) << z;
    EXPECT_FALSE(SweepSphereMesh(bvh, {-0.75, 0.75, z}, {0.75, -0.75, z}, r).hit) << z;
    // over the box's edge and corner, and off the box
    EXPECT_FALSE(SweepSphereMesh(bvh, {0.5, 0, z}, {1.5, 0, z}, r).hit) << z;
    EXPECT_FALSE(SweepSphereMesh(bvh, {0.5, 0.5, z}, {1.5, 1.5, z}, r).hit) << z;
  }
  // random radii, rest heights 1 + r rounded, directions in the plane
  std::mt19937_64 rng(306);
  std::uniform_real_distribution<double> unit(0, 1), inner(-0.9, 0.9);
  int blocked = 0;
  for (int k = 0; k < 1000; ++k) {
    const double radius = 0.05 + 0.3 * unit(rng);
    const Vector3 a(inner(rng), inner(rng), 1 + radius);
    const double angle = 2 * std::numbers::pi * unit(rng);
    const Vector3 slide = a + unit(rng) * Vector3(std::cos(angle), std::sin(angle), 0);
    EXPECT_FALSE(SweepSphereMesh(bvh, a, slide, radius).hit) << k;
    // straight into the face, however slightly beyond the skin: stopped at once (or
    // after sinking by the rounding of 1 + r, where that left the sphere above r)
    const double sink = 1e-6 + 0.1 * unit(rng);
    const SphereSweepHit down = SweepSphereMesh(bvh, a, a - sink * kUp, radius);
    ASSERT_TRUE(down.hit) << k;
    EXPECT_LE(down.t * sink, 1e-15) << k;
    EXPECT_EQ(down.normal, kUp) << k;
    EXPECT_EQ(down.point.z(), 1) << k;
    EXPECT_EQ(mesh->face_normal(down.triangle), kUp) << k;
    // sinking while sliding: stopped within the motion that sinks it by the skin (where
    // it leaves the triangle below before then, by the next one's edge)
    const SphereSweepHit sliding = SweepSphereMesh(bvh, a, slide - sink * kUp, radius);
    ASSERT_TRUE(sliding.hit) << k;
    EXPECT_LE(sliding.t * sink, CalcSphereSweepSkin(a, slide, radius)) << k;
    EXPECT_GT(sliding.normal.z(), 0.999) << k;
    EXPECT_EQ(sliding.point.z(), 1) << k;
    blocked += sliding.t * sink <= 1e-15;
  }
  // nearly always at once
  EXPECT_GT(blocked, 900);
}

TEST(SphereSweepMesh, PointSlidingOnAFlatFaceIsNeverBlocked) {
  const auto mesh = Share(MakeBoxMesh({1, 1, 1}, 8));
  const MeshBvh bvh(mesh);
  // on the face exactly, through its vertices and along its edges
  for (double y : {0.0, 0.25, 0.3}) {
    const Vector3 a(-0.875, y, 1), b(0.875, y, 1);
    EXPECT_FALSE(SweepSphereMesh(bvh, a, b, 0).hit) << y;
    EXPECT_FALSE(SweepSphereMesh(bvh, {-0.75, -0.75, 1}, {0.75, 0.75, 1}, 0).hit);
    // a little off the face (as a proxy keeps itself), also over the box's edge
    EXPECT_FALSE(SweepSphereMesh(bvh, a + 1e-9 * kUp, Vector3(1.5, y, 1 + 1e-9), 0).hit) << y;
    // exactly on it, over the box's edge: the side face is crossed from behind (both
    // sides block), at the edge
    const SphereSweepHit over = SweepSphereMesh(bvh, a, Vector3(1.5, y, 1), 0);
    ASSERT_TRUE(over.hit) << y;
    EXPECT_EQ(over.point, Vector3(1, y, 1));
    EXPECT_EQ(over.normal, -Vector3::UnitX());
    // out: free; in: stopped at once
    EXPECT_FALSE(SweepSphereMesh(bvh, a, b + 0.1 * kUp, 0).hit) << y;
    const SphereSweepHit hit = SweepSphereMesh(bvh, a, b - 0.1 * kUp, 0);
    ASSERT_TRUE(hit.hit) << y;
    EXPECT_EQ(hit.t, 0);
    EXPECT_EQ(hit.normal, kUp);
    EXPECT_EQ(hit.point, a);
  }
}

// Aimed exactly through a vertex or an edge shared by triangles of a closed mesh, a point
// or a sphere never gets through.
TEST(SphereSweepMesh, AimedAtSharedVerticesAndEdgesNeverSlipsThrough) {
  std::mt19937_64 rng(307);
  std::uniform_int_distribution<int> skew(-3, 3);
  // the box: dyadic vertices, so edge midpoints and the aims are exact
  const auto box = Share(MakeBoxMesh({1, 1, 1}, 4));
  const MeshBvh box_bvh(box);
  int aims = 0;
  for (int t : box->nondegenerate_triangles()) {
    const Triangle tri = box->triangle(t);
    const Vector3 n = box->face_normal(t);
    for (const Vector3& target : {tri.v0, Vector3(0.5 * (tri.v0 + tri.v1)),
                                  Vector3(0.5 * (tri.v1 + tri.v2))}) {
      // in along the face normal, skewed: exactly through the target at t = 1/2
      const Vector3 w = 0.5 * n + Vector3(skew(rng), skew(rng), skew(rng)) / 16;
      if (w.dot(n) <= 0.25) continue;
      const Vector3 a = target + w, b = target - w;
      const SphereSweepHit point = SweepSphereMesh(box_bvh, a, b, 0);
      ASSERT_TRUE(point.hit) << target.transpose();
      EXPECT_EQ(point.t, 0.5);
      for (double r : {0.125, 0.01}) {
        const SphereSweepHit sphere = SweepSphereMesh(box_bvh, a, b, r);
        ASSERT_TRUE(sphere.hit) << target.transpose() << " r " << r;
        EXPECT_LT(sphere.t, point.t);
        EXPECT_NEAR(DistanceTo(*box, At(a, b, sphere.t)), r, 1e-12);
      }
      ++aims;
    }
  }
  EXPECT_GT(aims, 300);
  // the icosphere: its vertices, aimed at from 2 v towards v / 2 (exactly through v)
  const auto ball = Share(MakeIcosphere(5, 1.0));
  const MeshBvh ball_bvh(ball);
  for (const Vector3& v : ball->vertices()) {
    for (double r : {0.0, 1e-3, 0.1}) {
      const SphereSweepHit hit = SweepSphereMesh(ball_bvh, 2 * v, 0.5 * v, r);
      ASSERT_TRUE(hit.hit) << v.transpose() << " r " << r;
      EXPECT_LE(hit.t, 2.0 / 3 + 1e-12);
    }
  }
  // and its edge midpoints (rounded, still on or just beside the edge)
  for (int t : ball->nondegenerate_triangles()) {
    const Triangle tri = ball->triangle(t);
    const Vector3 m = 0.5 * (tri.v0 + tri.v1);
    for (double r : {0.0, 1e-3}) {
      ASSERT_TRUE(SweepSphereMesh(ball_bvh, 2 * m, 0.5 * m, r).hit) << t << " r " << r;
    }
  }
}

TEST(SphereSweepMesh, SlidingAlongAFloorStopsAtAWall) {
  // an open L: floor z = 0 on [0, 4]^2 and a wall x = 4 rising to z = 4 (facing -x)
  const TriangleMesh l_shape({{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}, {4, 0, 4}, {4, 4, 4}},
                             {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}});
  ASSERT_EQ(l_shape.face_normal(2), -Vector3::UnitX());
  const MeshBvh bvh(Share(l_shape));
  const SphereSweepHit hit = SweepSphereMesh(bvh, {1, 2, 1}, {5, 2, 1}, 1);
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 0.5);
  EXPECT_EQ(hit.normal, -Vector3::UnitX());
  EXPECT_EQ(hit.point, Vector3(4, 2, 1));
  EXPECT_GE(hit.triangle, 2);
  EXPECT_EQ(hit.feature, Feature::kFace);
  // diagonally down into the corner: touches the floor and the wall at once
  const SphereSweepHit corner = SweepSphereMesh(bvh, {1, 2, 3}, {5, 2, -1}, 1);
  ASSERT_TRUE(corner.hit);
  EXPECT_NEAR(DistanceTo(l_shape, At({1, 2, 3}, {5, 2, -1}, corner.t)), 1, 1e-12);
  // a point on the floor, sliding into the wall: stopped at the wall
  const SphereSweepHit point = SweepSphereMesh(bvh, {1, 2, 0}, {5, 2, 0}, 0);
  ASSERT_TRUE(point.hit);
  EXPECT_EQ(point.t, 0.75);
  EXPECT_EQ(point.normal, -Vector3::UnitX());
}

TEST(SphereSweepMesh, NonFiniteOrMotionlessInputMisses) {
  const MeshBvh bvh(Share(MakeIcosphere(4, 1.0)));
  const Vector3 a(0, 0, 2), b(0, 0, 0);
  ASSERT_TRUE(SweepSphereMesh(bvh, a, b, 0.1).hit);
  for (double bad : {kNan, kInf, -kInf}) {
    for (int i = 0; i < 3; ++i) {
      Vector3 a_bad = a, b_bad = b;
      a_bad[i] = bad;
      b_bad[i] = bad;
      EXPECT_FALSE(SweepSphereMesh(bvh, a_bad, b, 0.1).hit);
      EXPECT_FALSE(SweepSphereMesh(bvh, a, b_bad, 0).hit);
    }
    EXPECT_FALSE(SweepSphereMesh(bvh, a, b, bad).hit);
  }
  EXPECT_FALSE(SweepSphereMesh(bvh, a, b, -0.1).hit);
  EXPECT_FALSE(SweepSphereMesh(bvh, {0, 0, 1}, {0, 0, 1}, 0.1).hit);
  // axis-aligned sweeps (zero direction components in the slab tests) still hit; the
  // mesh lies within the unit ball, so not before the centre is 2 from the origin
  const SphereSweepHit axis = SweepSphereMesh(bvh, {0, 0, 3}, {0, 0, 0}, 1);
  ASSERT_TRUE(axis.hit);
  EXPECT_GE(axis.t, 1.0 / 3 - 1e-15);
  EXPECT_NEAR(DistanceTo(bvh.mesh(), At({0, 0, 3}, {0, 0, 0}, axis.t)), 1, 1e-12);
}

}  // namespace
}  // namespace hapticd::geometry
