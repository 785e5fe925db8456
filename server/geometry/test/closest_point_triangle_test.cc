#include "server/geometry/closest_point_triangle.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "server/geometry/exact_predicates.h"
#include "server/geometry/test/non_finite.h"

namespace hapticd::geometry {
namespace {

const Triangle kTri{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};

// Independent oracle: project onto the plane by least squares (u, v from a QR solve);
// if the projection is inside, it is the answer; otherwise the answer is the nearest
// of the three edges' clamped projections. No Voronoi-region logic.
struct Oracle {
  Vector3 point;
  double distance;
};

Vector3 ClosestOnSegment(const Vector3& p, const Vector3& a, const Vector3& b) {
  const Vector3 d = b - a;
  const double len2 = d.squaredNorm();
  const double s = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return a + s * d;
}

Oracle ClosestByProjection(const Vector3& p, const Triangle& t) {
  Eigen::Matrix<double, 3, 2> m;
  m << t.v1 - t.v0, t.v2 - t.v0;
  const Vector2 uv = m.colPivHouseholderQr().solve(p - t.v0);
  if (uv.x() >= 0 && uv.y() >= 0 && uv.x() + uv.y() <= 1) {
    const Vector3 x = t.v0 + m * uv;
    return {x, (p - x).norm()};
  }
  Oracle best{Vector3::Zero(), std::numeric_limits<double>::infinity()};
  for (const auto& [a, b] : {std::pair(t.v0, t.v1), std::pair(t.v1, t.v2), std::pair(t.v2, t.v0)}) {
    const Vector3 x = ClosestOnSegment(p, a, b);
    if ((p - x).norm() < best.distance) best = {x, (p - x).norm()};
  }
  return best;
}

// Dense barycentric sampling: no sample may be closer than the reported point.
double ClosestSampleDistance(const Vector3& p, const Triangle& t, int n) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
      best = std::min(best, (p - ((1 - u - v) * t.v0 + u * t.v1 + v * t.v2)).norm());
    }
  }
  return best;
}

// The fields agree: distance_squared matches point, point matches (u, v), and the
// feature matches the barycentrics.
void ExpectConsistent(const ClosestPointOnTriangle& c, const Vector3& p, const Triangle& t) {
  const double scale = 1 + t.v0.norm() + t.v1.norm() + t.v2.norm();
  EXPECT_NEAR(c.distance_squared, (p - c.point).squaredNorm(), 1e-14 * scale * scale);
  EXPECT_LE(((1 - c.u - c.v) * t.v0 + c.u * t.v1 + c.v * t.v2 - c.point).norm(), 1e-13 * scale);
  EXPECT_GE(c.u, 0);
  EXPECT_GE(c.v, 0);
  EXPECT_LE(c.u + c.v, 1 + 1e-15);
  switch (c.feature) {
    case TriangleFeature::kVertex0: EXPECT_TRUE(c.u == 0 && c.v == 0); break;
    case TriangleFeature::kVertex1: EXPECT_TRUE(c.u == 1 && c.v == 0); break;
    case TriangleFeature::kVertex2: EXPECT_TRUE(c.u == 0 && c.v == 1); break;
    case TriangleFeature::kEdge01: EXPECT_EQ(c.v, 0); break;
    case TriangleFeature::kEdge12: EXPECT_NEAR(c.u + c.v, 1, 1e-15); break;
    case TriangleFeature::kEdge20: EXPECT_EQ(c.u, 0); break;
    case TriangleFeature::kFace: break;
  }
}

// ---------------------------------------------------------------------------------
// One exact case per Voronoi region.

TEST(ClosestPointOnTriangle, EachRegion) {
  struct Case {
    Vector3 p, point;
    double u, v;
    TriangleFeature feature;
  };
  const Case cases[] = {
      {{0.5, 0.5, 3}, {0.5, 0.5, 0}, 0.25, 0.25, TriangleFeature::kFace},
      {{0.5, 0.5, -3}, {0.5, 0.5, 0}, 0.25, 0.25, TriangleFeature::kFace},
      {{-1, -1, 1}, {0, 0, 0}, 0, 0, TriangleFeature::kVertex0},
      {{3, -1, 0}, {2, 0, 0}, 1, 0, TriangleFeature::kVertex1},
      {{-1, 3, 2}, {0, 2, 0}, 0, 1, TriangleFeature::kVertex2},
      {{1, -1, 1}, {1, 0, 0}, 0.5, 0, TriangleFeature::kEdge01},
      {{2, 2, -1}, {1, 1, 0}, 0.5, 0.5, TriangleFeature::kEdge12},
      {{-1, 0.5, 0}, {0, 0.5, 0}, 0, 0.25, TriangleFeature::kEdge20},
  };
  for (const Case& c : cases) {
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(c.p, kTri);
    EXPECT_EQ(r.point, c.point) << c.p.transpose();
    EXPECT_EQ(r.u, c.u) << c.p.transpose();
    EXPECT_EQ(r.v, c.v) << c.p.transpose();
    EXPECT_EQ(r.feature, c.feature) << c.p.transpose();
    EXPECT_EQ(r.distance_squared, (c.p - c.point).squaredNorm());
  }
}

TEST(ClosestPointOnTriangle, PointsOnTheTriangleAreTheirOwnClosestPoint) {
  for (const Vector3& p : {Vector3(0.5, 0.5, 0), Vector3(1, 0, 0), Vector3(1, 1, 0),
                           Vector3(0, 1.5, 0), Vector3(0, 0, 0), Vector3(2, 0, 0),
                           Vector3(0, 2, 0)}) {
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, kTri);
    EXPECT_EQ(r.point, p);
    EXPECT_EQ(r.distance_squared, 0);
    ExpectConsistent(r, p, kTri);
  }
}

TEST(ClosestPointOnTriangle, OnRegionBoundariesEitherFeatureGivesThePoint) {
  // on the boundary between v1's region and edge v0-v1's region, and so on
  const std::pair<Vector3, Vector3> cases[] = {
      {{2, -1, 0}, {2, 0, 0}}, {{0, -1, 1}, {0, 0, 0}}, {{-1, 0, 1}, {0, 0, 0}},
      {{3, 1, 0}, {2, 0, 0}},  {{1, 3, 0}, {0, 2, 0}},  {{-1, 2, 0}, {0, 2, 0}}};
  for (const auto& [p, expected] : cases) {
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, kTri);
    EXPECT_EQ(r.point, expected) << p.transpose();
    ExpectConsistent(r, p, kTri);
  }
}

// ---------------------------------------------------------------------------------
// Random points and triangles against the oracles, and invariants.

TEST(ClosestPointOnTriangle, MatchesProjectionOracleOnRandomCases) {
  std::mt19937_64 rng(51);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 100000; ++n) {
    const double scale = std::pow(10.0, static_cast<int>(rng() % 7) - 3);
    const Vector3 centre = Vector3(u(rng), u(rng), u(rng)) * 50 * scale;
    const auto point = [&] { return Vector3(centre + scale * Vector3(u(rng), u(rng), u(rng))); };
    const Triangle t{point(), point(), point()};
    const Vector3 p = centre + 2 * scale * Vector3(u(rng), u(rng), u(rng));
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, t);
    const Oracle o = ClosestByProjection(p, t);
    ASSERT_NEAR(std::sqrt(r.distance_squared), o.distance, 1e-12 * scale) << "case " << n;
    EXPECT_LE((r.point - o.point).norm(), 1e-9 * scale) << "case " << n;
    ExpectConsistent(r, p, t);
  }
}

TEST(ClosestPointOnTriangle, NoSampleOfTheTriangleIsCloser) {
  std::mt19937_64 rng(52);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 300; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Vector3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, t);
    const double sampled = ClosestSampleDistance(p, t, 200);
    EXPECT_LE(std::sqrt(r.distance_squared), sampled + 1e-14);
    // and the dense samples come close to it (a 200-grid is within ~1% of the size)
    EXPECT_LE(sampled - std::sqrt(r.distance_squared), 0.02);
  }
}

TEST(ClosestPointOnTriangle, RigidMotionsAndVertexRotationsChangeNothing) {
  std::mt19937_64 rng(53);
  std::uniform_real_distribution<double> u(-1, 1);
  const auto rotate_feature = [](TriangleFeature f) {
    // for the triangle (v1, v2, v0): its vertex 0 is our vertex 1, and so on
    switch (f) {
      case TriangleFeature::kVertex1: return TriangleFeature::kVertex0;
      case TriangleFeature::kVertex2: return TriangleFeature::kVertex1;
      case TriangleFeature::kVertex0: return TriangleFeature::kVertex2;
      case TriangleFeature::kEdge12: return TriangleFeature::kEdge01;
      case TriangleFeature::kEdge20: return TriangleFeature::kEdge12;
      case TriangleFeature::kEdge01: return TriangleFeature::kEdge20;
      case TriangleFeature::kFace: return TriangleFeature::kFace;
    }
    return f;
  };
  for (int n = 0; n < 5000; ++n) {
    const Triangle t{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    const Vector3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, t);
    // rotating the vertex order moves the same point, relabels the feature
    const ClosestPointOnTriangle rot = FindClosestPointOnTriangle(p, {t.v1, t.v2, t.v0});
    EXPECT_LE((rot.point - r.point).norm(), 1e-13);
    EXPECT_EQ(rot.feature, rotate_feature(r.feature)) << "case " << n;
    // rotating and translating everything
    const Matrix3 m = Eigen::AngleAxisd(3 * u(rng), Vector3(u(rng), u(rng), u(rng)).normalized())
                          .toRotationMatrix();
    const Vector3 shift(10 * u(rng), 10 * u(rng), 10 * u(rng));
    const auto move = [&](const Vector3& x) { return Vector3(m * x + shift); };
    const ClosestPointOnTriangle moved =
        FindClosestPointOnTriangle(move(p), {move(t.v0), move(t.v1), move(t.v2)});
    EXPECT_NEAR(moved.distance_squared, r.distance_squared, 1e-12);
    EXPECT_LE((moved.point - move(r.point)).norm(), 1e-12);
    EXPECT_EQ(moved.feature, r.feature) << "case " << n;
  }
}

// The distance to a triangle whose corners are (nearly) collinear: the distance to the
// segment they span, whichever edge that is.
double DistanceToSpan(const Vector3& p, const Triangle& t) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [x, y] : {std::pair(t.v0, t.v1), std::pair(t.v1, t.v2), std::pair(t.v2, t.v0)}) {
    best = std::min(best, (p - ClosestOnSegment(p, x, y)).norm());
  }
  return best;
}

TEST(ClosestPointOnTriangle, DegenerateTrianglesGiveTheSegmentOrPoint) {
  std::mt19937_64 rng(54);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 3000; ++n) {
    const Vector3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
    const Vector3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    // exactly zero area: a repeated corner (in any position), or all three equal
    Triangle t;
    switch (n % 4) {
      case 0: t = {a, a, a}; break;
      case 1: t = {a, b, b}; break;
      case 2: t = {a, b, a}; break;
      default: t = {b, a, a}; break;
    }
    ASSERT_TRUE(IsDegenerateTriangle(t.v0, t.v1, t.v2));
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, t);
    EXPECT_NEAR(std::sqrt(r.distance_squared), DistanceToSpan(p, t), 1e-12) << "case " << n;
    EXPECT_TRUE(r.point.allFinite());
    EXPECT_TRUE(std::isfinite(r.u) && std::isfinite(r.v));
    EXPECT_NE(r.feature, TriangleFeature::kFace);
  }
}

// Slivers: the third corner computed as a + lambda (b - a), so the corners are collinear
// up to rounding (area ~1e-16 against edges ~1). The closest point is still (to
// rounding) the closest point of the segment they span.
TEST(ClosestPointOnTriangle, NearlyCollinearSliversGiveTheSpannedSegment) {
  std::mt19937_64 rng(54);
  std::uniform_real_distribution<double> u(-1, 1);
  int failures = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vector3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
    const Vector3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const double lambda = n % 3 == 0 ? 0.5 : (n % 3 == 1 ? 2.0 : -0.75);
    const Triangle t{a, b, a + lambda * (b - a)};
    const ClosestPointOnTriangle r = FindClosestPointOnTriangle(p, t);
    const double expected = DistanceToSpan(p, t);
    failures += std::abs(std::sqrt(r.distance_squared) - expected) > 1e-9;
    EXPECT_NEAR(std::sqrt(r.distance_squared), expected, 1e-9) << "case " << n;
  }
  RecordProperty("sliver_failures", failures);
}

// The header's promise: a non-finite coordinate in the point or the triangle gives NaN
// in the point, the barycentrics and the distance (never a contact).
TEST(ClosestPointOnTriangle, NonFiniteInputGivesNaNFields) {
  for (const Vector3& p : {Vector3(0.5, 0.5, 1), Vector3(-1, -1, 0), Vector3(3, 0, 0)}) {
    const auto check = [](const ClosestPointOnTriangle& c, const std::string& what) {
      EXPECT_TRUE(c.point.array().isNaN().all() && std::isnan(c.u) && std::isnan(c.v) &&
                  std::isnan(c.distance_squared))
          << what << ": point " << c.point.transpose() << " d2 " << c.distance_squared;
    };
    for (const Triangle& tri : WithOneNonFiniteField(kTri)) {
      check(FindClosestPointOnTriangle(p, tri), "a bad triangle");
    }
    for (const Vector3& bad : WithOneNonFiniteField(p)) check(FindClosestPointOnTriangle(bad, kTri), "a bad point");
  }
}

}  // namespace
}  // namespace hapticd::geometry
