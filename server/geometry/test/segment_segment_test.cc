#include "server/geometry/segment_segment.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "server/geometry/test/non_finite.h"

namespace hapticd::geometry {
namespace {

// Independent oracle: g(s) = min over t of |a(s) - b(t)|² is convex in s (a partial
// minimum of a jointly convex function), and for fixed s the best t is a clamped
// projection. Golden-section search on s finds the minimum without any case analysis.
double BestT(const Vector3& x, const Vector3& q0, const Vector3& q1) {
  const Vector3 d = q1 - q0;
  const double len2 = d.squaredNorm();
  return len2 > 0 ? std::clamp((x - q0).dot(d) / len2, 0.0, 1.0) : 0.0;
}

double OracleDistanceSquared(const Vector3& p0, const Vector3& p1, const Vector3& q0,
                             const Vector3& q1) {
  const auto g = [&](double s) {
    const Vector3 x = p0 + s * (p1 - p0);
    const double t = BestT(x, q0, q1);
    return (x - (q0 + t * (q1 - q0))).squaredNorm();
  };
  double lo = 0, hi = 1;
  const double ratio = (std::sqrt(5.0) - 1) / 2;
  double m1 = hi - ratio * (hi - lo), m2 = lo + ratio * (hi - lo);
  double g1 = g(m1), g2 = g(m2);
  for (int i = 0; i < 200; ++i) {
    if (g1 <= g2) {
      hi = m2;
      m2 = m1;
      g2 = g1;
      m1 = hi - ratio * (hi - lo);
      g1 = g(m1);
    } else {
      lo = m1;
      m1 = m2;
      g1 = g2;
      m2 = lo + ratio * (hi - lo);
      g2 = g(m2);
    }
  }
  return std::min({g(0), g(1), g(0.5 * (lo + hi))});
}

// The fields agree with each other: parameters in range, points on their segments.
void ExpectConsistent(const SegmentSegmentClosest& r, const Vector3& p0, const Vector3& p1,
                      const Vector3& q0, const Vector3& q1) {
  EXPECT_GE(r.s, 0);
  EXPECT_LE(r.s, 1);
  EXPECT_GE(r.t, 0);
  EXPECT_LE(r.t, 1);
  const double scale = 1 + p0.norm() + p1.norm() + q0.norm() + q1.norm();
  EXPECT_LE((r.point_a - (p0 + r.s * (p1 - p0))).norm(), 1e-14 * scale);
  EXPECT_LE((r.point_b - (q0 + r.t * (q1 - q0))).norm(), 1e-14 * scale);
  EXPECT_NEAR(r.distance_squared, (r.point_a - r.point_b).squaredNorm(), 1e-14 * scale * scale);
}

TEST(SegmentSegment, PerpendicularSkewSegments) {
  const SegmentSegmentClosest r =
      FindClosestPointsBetweenSegments({-1, 0, 0}, {1, 0, 0}, {0.5, -1, 2}, {0.5, 1, 2});
  EXPECT_DOUBLE_EQ(r.s, 0.75);
  EXPECT_DOUBLE_EQ(r.t, 0.5);
  EXPECT_EQ(r.point_a, Vector3(0.5, 0, 0));
  EXPECT_EQ(r.point_b, Vector3(0.5, 0, 2));
  EXPECT_DOUBLE_EQ(r.distance_squared, 4);
}

TEST(SegmentSegment, CrossingSegmentsHaveZeroDistance) {
  const SegmentSegmentClosest r =
      FindClosestPointsBetweenSegments({0, 0, 0}, {2, 2, 0}, {0, 2, 0}, {2, 0, 0});
  EXPECT_EQ(r.distance_squared, 0);
  EXPECT_EQ(r.point_a, Vector3(1, 1, 0));
}

TEST(SegmentSegment, ClampedToEndpoints) {
  // the lines cross at x = 3, beyond a's end: the closest point of a is its end
  const SegmentSegmentClosest r =
      FindClosestPointsBetweenSegments({0, 0, 0}, {2, 0, 0}, {3, -1, 1}, {3, 1, 1});
  EXPECT_EQ(r.s, 1);
  EXPECT_DOUBLE_EQ(r.t, 0.5);
  EXPECT_DOUBLE_EQ(r.distance_squared, 2);
  // both clamped: endpoint to endpoint
  const SegmentSegmentClosest e =
      FindClosestPointsBetweenSegments({0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {2, 3, 0});
  EXPECT_EQ(e.s, 1);
  EXPECT_EQ(e.t, 0);
  EXPECT_DOUBLE_EQ(e.distance_squared, 2);
}

TEST(SegmentSegment, ParallelSegments) {
  // overlapping side by side: distance is the gap, the pair is any overlapping pair
  SegmentSegmentClosest r =
      FindClosestPointsBetweenSegments({0, 0, 0}, {4, 0, 0}, {1, 1, 0}, {6, 1, 0});
  EXPECT_DOUBLE_EQ(r.distance_squared, 1);
  EXPECT_GE(r.point_a.x(), 1);
  EXPECT_LE(r.point_a.x(), 4);
  EXPECT_DOUBLE_EQ(r.point_a.x(), r.point_b.x());
  // antiparallel, disjoint along the line: end to end
  r = FindClosestPointsBetweenSegments({0, 0, 0}, {1, 0, 0}, {5, 1, 0}, {3, 1, 0});
  EXPECT_DOUBLE_EQ(r.distance_squared, 5);
  EXPECT_EQ(r.point_a, Vector3(1, 0, 0));
  EXPECT_EQ(r.point_b, Vector3(3, 1, 0));
  // collinear overlapping: zero
  r = FindClosestPointsBetweenSegments({0, 0, 0}, {2, 0, 0}, {1, 0, 0}, {3, 0, 0});
  EXPECT_EQ(r.distance_squared, 0);
}

TEST(SegmentSegment, ZeroLengthSegments) {
  SegmentSegmentClosest r =
      FindClosestPointsBetweenSegments({1, 1, 1}, {1, 1, 1}, {0, 0, 0}, {2, 0, 0});
  EXPECT_EQ(r.s, 0);
  EXPECT_DOUBLE_EQ(r.t, 0.5);
  EXPECT_DOUBLE_EQ(r.distance_squared, 2);
  r = FindClosestPointsBetweenSegments({0, 0, 0}, {2, 0, 0}, {3, 1, 0}, {3, 1, 0});
  EXPECT_EQ(r.s, 1);
  EXPECT_EQ(r.t, 0);
  EXPECT_DOUBLE_EQ(r.distance_squared, 2);
  r = FindClosestPointsBetweenSegments({0, 0, 0}, {0, 0, 0}, {0, 3, 4}, {0, 3, 4});
  EXPECT_DOUBLE_EQ(r.distance_squared, 25);
  EXPECT_FALSE(std::isnan(r.s) || std::isnan(r.t));
}

TEST(SegmentSegment, SwapAndReverseInvariants) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 2000; ++n) {
    const Vector3 p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng));
    const Vector3 q0(u(rng), u(rng), u(rng)), q1(u(rng), u(rng), u(rng));
    const SegmentSegmentClosest r = FindClosestPointsBetweenSegments(p0, p1, q0, q1);
    const SegmentSegmentClosest swapped = FindClosestPointsBetweenSegments(q0, q1, p0, p1);
    const SegmentSegmentClosest reversed = FindClosestPointsBetweenSegments(p1, p0, q0, q1);
    EXPECT_NEAR(r.distance_squared, swapped.distance_squared, 1e-14);
    EXPECT_NEAR(r.distance_squared, reversed.distance_squared, 1e-14);
    // generic segments have a unique closest pair
    EXPECT_NEAR(r.s, swapped.t, 1e-9);
    EXPECT_NEAR(r.t, swapped.s, 1e-9);
    EXPECT_NEAR(r.s, 1 - reversed.s, 1e-9);
    // moving both segments moves the points and keeps the distance
    const Vector3 shift(37.25, -12.5, 3);
    const SegmentSegmentClosest moved =
        FindClosestPointsBetweenSegments(p0 + shift, p1 + shift, q0 + shift, q1 + shift);
    EXPECT_NEAR(moved.distance_squared, r.distance_squared, 1e-12);
    EXPECT_LE((moved.point_a - shift - r.point_a).norm(), 1e-9);
  }
}

TEST(SegmentSegment, MatchesOracleOnRandomSegments) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 20000; ++n) {
    const Vector3 p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng));
    const Vector3 q0(u(rng), u(rng), u(rng)), q1(u(rng), u(rng), u(rng));
    const SegmentSegmentClosest r = FindClosestPointsBetweenSegments(p0, p1, q0, q1);
    ExpectConsistent(r, p0, p1, q0, q1);
    EXPECT_NEAR(std::sqrt(r.distance_squared), std::sqrt(OracleDistanceSquared(p0, p1, q0, q1)),
                1e-9)
        << "case " << n;
  }
}

// Nearly parallel (angles down to 1e-15 rad), parallel, collinear and very short
// segments: the ill-conditioned cases the plain line-line formula gets wrong.
TEST(SegmentSegment, MatchesOracleOnNearlyParallelAndShortSegments) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> exponent(-16, 0);
  for (int n = 0; n < 20000; ++n) {
    const Vector3 dir = Vector3(u(rng), u(rng), u(rng)).normalized();
    const Vector3 tilt = Vector3(u(rng), u(rng), u(rng)) * std::pow(10.0, exponent(rng));
    const Vector3 p0(u(rng), u(rng), u(rng));
    const Vector3 p1 = p0 + dir * (n % 7 == 0 ? std::pow(10.0, exponent(rng)) : 1.0 + u(rng));
    const Vector3 q0 = p0 + Vector3(u(rng), u(rng), u(rng)) * (n % 3 == 0 ? 1e-3 : 0.5) +
                       (n % 5 == 0 ? Vector3::Zero() : Vector3(dir * u(rng)));
    const Vector3 q1 = q0 + (dir + tilt) * (n % 11 == 0 ? 0.0 : 2 * u(rng));
    const SegmentSegmentClosest r = FindClosestPointsBetweenSegments(p0, p1, q0, q1);
    ExpectConsistent(r, p0, p1, q0, q1);
    const double expected = std::sqrt(OracleDistanceSquared(p0, p1, q0, q1));
    EXPECT_NEAR(std::sqrt(r.distance_squared), expected, 1e-9) << "case " << n;
  }
}

// The header's promise: a non-finite coordinate anywhere gives NaN in every field
// (never a distance, so no caller mistakes it for a contact).
TEST(SegmentSegment, NonFiniteInputGivesNaNFields) {
  const std::array<Vector3, 4> crossing{Vector3(-1, 0, 0), Vector3(1, 0, 0), Vector3(0, -1, 1), Vector3(0, 1, 1)};
  const std::array<Vector3, 4> zero_length{Vector3(0, 0, 0), Vector3(0, 0, 0), Vector3(0, 1, 0), Vector3(0, 2, 0)};
  for (const auto& clean : {crossing, zero_length}) {
    for (const auto& e : WithOneNonFiniteField(clean)) {
      const SegmentSegmentClosest r = FindClosestPointsBetweenSegments(e[0], e[1], e[2], e[3]);
      EXPECT_TRUE(std::isnan(r.s) && std::isnan(r.t) && r.point_a.array().isNaN().all() &&
                  r.point_b.array().isNaN().all() && std::isnan(r.distance_squared))
          << "s " << r.s << " t " << r.t << " d2 " << r.distance_squared << " for " << e[0].transpose() << " | "
          << e[1].transpose() << " | " << e[2].transpose() << " | " << e[3].transpose();
    }
  }
}

}  // namespace
}  // namespace hapticd::geometry
