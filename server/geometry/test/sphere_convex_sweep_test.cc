#include "server/geometry/sphere_convex_sweep.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "server/geometry/convex_hull.h"
#include "server/geometry/point_hull.h"
#include "server/geometry/sphere_box.h"
#include "server/geometry/sphere_sphere.h"
#include "server/geometry/test/non_finite.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTolerance = kConvexSweepTolerance;
const Sphere kUnitBall{Vector3::Zero(), 1};

// Distance oracles of convex solids, each counting the times it is asked.
struct BallOracle {
  Sphere ball;
  int* calls = nullptr;
  ConvexProbe operator()(const Vector3& p) const {
    if (calls != nullptr) ++*calls;
    const SphereSphereResult contact = CollideSpheres(ball, {p, 0});
    return {true, contact.distance, contact.point_a, contact.normal};
  }
};

struct BoxOracle {
  Vector3 half_extents;
  int* calls = nullptr;
  ConvexProbe operator()(const Vector3& p) const {
    if (calls != nullptr) ++*calls;
    const SphereBoxResult contact = CollideSphereBox({p, 0}, {Vector3::Zero(), Matrix3::Identity(), half_extents});
    return {true, contact.distance, contact.point_box, contact.normal};
  }
};

struct HullOracle {
  const ConvexHull* hull;
  ConvexProbe operator()(const Vector3& p) const {
    const PointHullResult nearest = CalcPointHullDistance(*hull, p);
    return {nearest.found, nearest.signed_distance, nearest.point, nearest.normal};
  }
};

// Any answer a test makes up, through a std::function.
struct FunctionOracle {
  std::function<ConvexProbe(const Vector3&)> answer;
  ConvexProbe operator()(const Vector3& p) const { return answer(p); }
};

void ExpectMiss(const ConvexSweepHit& hit) {
  EXPECT_FALSE(hit.hit);
  EXPECT_EQ(hit.t, 0);
  EXPECT_EQ(hit.point, Vector3::Zero());
  EXPECT_EQ(hit.normal, Vector3::UnitZ());
}

void ExpectHitAt(const ConvexSweepHit& hit, double t, const Vector3& point, const Vector3& normal, double tolerance) {
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.t, t, tolerance);
  EXPECT_NEAR((hit.point - point).norm(), 0, tolerance) << hit.point.transpose();
  EXPECT_NEAR((hit.normal - normal).norm(), 0, tolerance) << hit.normal.transpose();
}

// Both kernels against the same ball: the closed form and the advancement over its oracle.
ConvexSweepHit AdvanceAgainst(const Sphere& ball, const Vector3& a, const Vector3& b, double r) {
  return SweepSphereConvex(BallOracle{ball}, a, b, r);
}

// ---------------------------------------------------------------------------------
// Exact answers on hand-built cases.

TEST(SweepSphereSphere, HeadOnStopsWhereTheGapIsTheTolerance) {
  // |x| = 1 + 0.5 + tolerance, reached from x = 3 moving 6 to the left
  const ConvexSweepHit hit = SweepSphereSphere(kUnitBall, {3, 0, 0}, {-3, 0, 0}, 0.5);
  ExpectHitAt(hit, (1.5 - kTolerance) / 6, {1, 0, 0}, {1, 0, 0}, 1e-15);
  // off-centre ball, the same motion relative to it
  const ConvexSweepHit shifted = SweepSphereSphere({{1, 2, 3}, 1}, {4, 2, 3}, {-2, 2, 3}, 0.5);
  ExpectHitAt(shifted, (1.5 - kTolerance) / 6, {2, 2, 3}, {1, 0, 0}, 1e-15);
}

TEST(SweepSphereSphere, GrazingPassFollowsTheAnalyticRoot) {
  // a point passing 0.6 from the centre of the unit ball: enters where x = -sqrt(rho^2 - 0.36)
  const double rho = 1 + kTolerance;
  const ConvexSweepHit crossing = SweepSphereSphere(kUnitBall, {-2, 0.6, 0}, {2, 0.6, 0}, 0);
  const double x = -std::sqrt(rho * rho - 0.36);
  ExpectHitAt(crossing, (x + 2) / 4, Vector3(x, 0.6, 0) / rho, Vector3(x, 0.6, 0) / rho, 1e-14);
  // exactly tangent: inside the tolerance for a short stretch around x = 0
  const ConvexSweepHit tangent = SweepSphereSphere(kUnitBall, {-2, 1, 0}, {2, 1, 0}, 0);
  ASSERT_TRUE(tangent.hit);
  EXPECT_NEAR(tangent.t, 0.5 - std::sqrt(rho * rho - 1) / 4, 1e-10);
  EXPECT_NEAR((tangent.normal - Vector3::UnitY()).norm(), 0, 1e-4);
  // passing a hair beyond the tolerance: a miss
  ExpectMiss(SweepSphereSphere(kUnitBall, {-2, 1 + 2 * kTolerance, 0}, {2, 1 + 2 * kTolerance, 0}, 0));
}

// The contact point and normal are CollideSpheres' at the contact centre, bit for bit,
// over random balls and sweeps (from outside, touching, inside, grazing).
TEST(SweepSphereSphere, ContactIsCollideSpheresAtTheContactCentre) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> coordinate(-3, 3), size(0, 1.5);
  std::normal_distribution<double> normal;
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Sphere ball{Vector3(coordinate(rng), coordinate(rng), coordinate(rng)), size(rng)};
    const double r = i % 2 == 0 ? 0 : size(rng);
    Vector3 a = ball.center + Vector3(coordinate(rng), coordinate(rng), coordinate(rng));
    // every fourth starts on the tolerance shell
    if (i % 4 == 1) {
      a = ball.center + (ball.radius + r + kTolerance) * Vector3(normal(rng), normal(rng), normal(rng)).normalized();
    }
    const Vector3 b = i % 8 == 3 ? ball.center : Vector3(a + Vector3(coordinate(rng), coordinate(rng), coordinate(rng)));
    const ConvexSweepHit hit = SweepSphereSphere(ball, a, b, r);
    if (!hit.hit) continue;
    ++hits;
    const SphereSphereResult contact = CollideSpheres(ball, {a + hit.t * (b - a), 0});
    ASSERT_EQ(hit.normal, contact.normal) << i;
    ASSERT_EQ(hit.point, contact.point_a) << i;
  }
  EXPECT_GT(hits, 2000);
}

TEST(SweepSphereConvex, BoxFaceIsReachedInOneStep) {
  // the gap 2 - 0.5 closes at 4 per unit t: one advancement to t = 0.375, one probe to confirm
  int calls = 0;
  const ConvexSweepHit hit = SweepSphereConvex(BoxOracle{Vector3::Ones(), &calls}, {0.2, 0.3, 3}, {0.2, 0.3, -1}, 0.5);
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.t, 0.375);
  EXPECT_EQ(hit.point, Vector3(0.2, 0.3, 1));
  EXPECT_EQ(hit.normal, Vector3::UnitZ());
  EXPECT_EQ(calls, 2);
}

TEST(SweepSphereConvex, CurvedSurfaceConvergesFromBelowInAFewSteps) {
  int calls = 0;
  const ConvexSweepHit hit = SweepSphereConvex(BallOracle{kUnitBall, &calls}, {-3, 0.5, 0}, {3, 0.5, 0}, 0.25);
  ASSERT_TRUE(hit.hit);
  // the iterates never pass the contact at gap 0 and stop within the tolerance of it
  const double exact = (3 - std::sqrt(1.25 * 1.25 - 0.25)) / 6;
  EXPECT_LE(hit.t, exact);
  EXPECT_GE(hit.t, SweepSphereSphere(kUnitBall, {-3, 0.5, 0}, {3, 0.5, 0}, 0.25).t - 1e-15);
  EXPECT_LE(calls, 10);
}

// ---------------------------------------------------------------------------------
// The degenerate answers of the header, one by one, for both kernels.

TEST(SphereConvexSweepDegenerate, NonFiniteInputMissesWithoutAskingTheSolid) {
  int calls = 0;
  const BallOracle oracle{kUnitBall, &calls};
  for (const auto& ends : WithOneNonFiniteField(std::array<Vector3, 2>{Vector3(3, 0, 0), Vector3(-3, 0, 0)})) {
    ExpectMiss(SweepSphereSphere(kUnitBall, ends[0], ends[1], 0.5));
    ExpectMiss(SweepSphereConvex(oracle, ends[0], ends[1], 0.5));
  }
  for (const double r : {kNan, kInf, -kInf}) {
    ExpectMiss(SweepSphereSphere(kUnitBall, {3, 0, 0}, {-3, 0, 0}, r));
    ExpectMiss(SweepSphereConvex(oracle, {3, 0, 0}, {-3, 0, 0}, r));
  }
  for (const Sphere& ball : WithOneNonFiniteField(kUnitBall)) {
    ExpectMiss(SweepSphereSphere(ball, {3, 0, 0}, {-3, 0, 0}, 0.5));
  }
  EXPECT_EQ(calls, 0);
}

TEST(SphereConvexSweepDegenerate, NegativeRadiusMisses) {
  int calls = 0;
  ExpectMiss(SweepSphereSphere(kUnitBall, {3, 0, 0}, {-3, 0, 0}, -0.5));
  ExpectMiss(SweepSphereConvex(BallOracle{kUnitBall, &calls}, {3, 0, 0}, {-3, 0, 0}, -0.5));
  ExpectMiss(SweepSphereSphere({Vector3::Zero(), -1}, {3, 0, 0}, {-3, 0, 0}, 0.5));
  EXPECT_EQ(calls, 0);
}

TEST(SphereConvexSweepDegenerate, NoMotionMissesEvenInside) {
  int calls = 0;
  for (const Vector3& a : {Vector3(3, 0, 0), Vector3(1.5, 0, 0), Vector3(0.5, 0, 0)}) {
    ExpectMiss(SweepSphereSphere(kUnitBall, a, a, 0.5));
    ExpectMiss(SweepSphereConvex(BallOracle{kUnitBall, &calls}, a, a, 0.5));
  }
  EXPECT_EQ(calls, 0);
}

TEST(SphereConvexSweepDegenerate, StartingInContactOnlyMotionIntoTheSurfaceHits) {
  const Vector3 on_top(0, 0, 1.25);  // r = 0.25: touching the unit ball and the unit box
  const BoxOracle box{Vector3::Ones()};
  // along the surface, or away from it: a miss
  for (const Vector3& step : {Vector3(0.5, 0, 0), Vector3(0, 0, 0.5), Vector3(0.3, 0.2, 0.1)}) {
    ExpectMiss(SweepSphereSphere(kUnitBall, on_top, on_top + step, 0.25));
    ExpectMiss(AdvanceAgainst(kUnitBall, on_top, on_top + step, 0.25));
    ExpectMiss(SweepSphereConvex(box, on_top, on_top + step, 0.25));
  }
  // into it: a hit at t = 0, at the nearest point of a
  const Vector3 into = on_top + Vector3(0.5, 0, -0.5);
  ExpectHitAt(SweepSphereSphere(kUnitBall, on_top, into, 0.25), 0, {0, 0, 1}, {0, 0, 1}, 0);
  ExpectHitAt(AdvanceAgainst(kUnitBall, on_top, into, 0.25), 0, {0, 0, 1}, {0, 0, 1}, 0);
  ExpectHitAt(SweepSphereConvex(box, on_top, into, 0.25), 0, {0, 0, 1}, {0, 0, 1}, 0);
  // within the tolerance counts as touching
  const Vector3 hovering(0, 0, 1.25 + 0.5 * kTolerance);
  EXPECT_EQ(SweepSphereSphere(kUnitBall, hovering, {0, 0, 0}, 0.25).t, 0);
  EXPECT_EQ(SweepSphereConvex(box, hovering, {0, 0, 0}, 0.25).t, 0);
}

TEST(SphereConvexSweepDegenerate, StartingInsideOnlyMotionDeeperHits) {
  // the centre 0.5 inside the unit ball (r = 0.25): held where it would go deeper
  const Vector3 a(0.5, 0, 0);
  ExpectHitAt(SweepSphereSphere(kUnitBall, a, {0, 0, 0}, 0.25), 0, {1, 0, 0}, {1, 0, 0}, 0);
  ExpectHitAt(AdvanceAgainst(kUnitBall, a, {0, 0, 0}, 0.25), 0, {1, 0, 0}, {1, 0, 0}, 0);
  ExpectMiss(SweepSphereSphere(kUnitBall, a, {3, 0, 0}, 0.25));
  ExpectMiss(AdvanceAgainst(kUnitBall, a, {3, 0, 0}, 0.25));
  ExpectMiss(SweepSphereSphere(kUnitBall, a, {0.5, 1, 0}, 0));
  // a box: the exit face's normal decides
  const BoxOracle box{Vector3::Ones()};
  ExpectHitAt(SweepSphereConvex(box, {0, 0, 0.8}, {0, 0, -0.8}, 0), 0, {0, 0, 1}, {0, 0, 1}, 0);
  ExpectMiss(SweepSphereConvex(box, {0, 0, 0.8}, {0, 0, 5}, 0));
}

TEST(SphereConvexSweepDegenerate, ParallelOrAwayWhileApartMisses) {
  const BoxOracle box{Vector3::Ones()};
  int calls = 0;
  ExpectMiss(SweepSphereConvex(BoxOracle{Vector3::Ones(), &calls}, {0, 0, 2}, {5, 0, 2}, 0.5));
  EXPECT_EQ(calls, 1);
  ExpectMiss(SweepSphereConvex(box, {0, 0, 2}, {0, 0, 4}, 0.5));
  ExpectMiss(SweepSphereSphere(kUnitBall, {0, 0, 2}, {0, 0, 4}, 0.5));
  ExpectMiss(AdvanceAgainst(kUnitBall, {0, 0, 2}, {0, 0, 4}, 0.5));
  // passing by: the gap falls, then rises again short of the tolerance
  ExpectMiss(SweepSphereSphere(kUnitBall, {-3, 0, 1.6}, {3, 0, 1.6}, 0.5));
  ExpectMiss(AdvanceAgainst(kUnitBall, {-3, 0, 1.6}, {3, 0, 1.6}, 0.5));
}

TEST(SphereConvexSweepDegenerate, ContactBeyondTheEndMissesAndAtTheEndHits) {
  const BoxOracle box{Vector3::Ones()};
  ExpectMiss(SweepSphereSphere(kUnitBall, {3, 0, 0}, {1.5 + 1e-6, 0, 0}, 0.5));
  ExpectMiss(AdvanceAgainst(kUnitBall, {3, 0, 0}, {1.5 + 1e-6, 0, 0}, 0.5));
  ExpectMiss(SweepSphereConvex(box, {3, 0, 0}, {1.5 + 1e-6, 0, 0}, 0.5));
  for (const ConvexSweepHit& hit :
       {SweepSphereSphere(kUnitBall, {3, 0, 0}, {1.5, 0, 0}, 0.5), AdvanceAgainst(kUnitBall, {3, 0, 0}, {1.5, 0, 0}, 0.5),
        SweepSphereConvex(box, {3, 0, 0}, {1.5, 0, 0}, 0.5)}) {
    ASSERT_TRUE(hit.hit);
    EXPECT_LE(hit.t, 1);
    EXPECT_NEAR(hit.t, 1, 1e-9);
  }
}

TEST(SphereConvexSweepDegenerate, PointsAndBallsOfRadiusZero) {
  // a point onto the box's face
  ExpectHitAt(SweepSphereConvex(BoxOracle{Vector3::Ones()}, {0.5, 0.5, 3}, {0.5, 0.5, -1}, 0), 0.5, {0.5, 0.5, 1},
              {0, 0, 1}, 0);
  // a ball of radius 0 is its centre: a sphere of radius 0.5 meets it at 0.5 + tolerance
  ExpectHitAt(SweepSphereSphere({Vector3::Zero(), 0}, {-2, 0, 0}, {2, 0, 0}, 0.5), (1.5 - kTolerance) / 4,
              Vector3::Zero(), {-1, 0, 0}, 1e-15);
  // a point against a ball of radius 0: unspecified, but a hit is at the centre
  for (const ConvexSweepHit& hit : {SweepSphereSphere({Vector3::Zero(), 0}, {-2, 0, 0}, {2, 0, 0}, 0),
                                    AdvanceAgainst({Vector3::Zero(), 0}, {-2, 0, 0}, {2, 0, 0}, 0)}) {
    if (!hit.hit) continue;
    EXPECT_NEAR(hit.t, 0.5, 1e-8);
    EXPECT_EQ(hit.point, Vector3::Zero());
    EXPECT_NEAR(hit.normal.norm(), 1, 1e-15);
  }
  ExpectMiss(SweepSphereSphere({Vector3::Zero(), 0}, {-2, 1e-6, 0}, {2, 1e-6, 0}, 0));
  ExpectMiss(AdvanceAgainst({Vector3::Zero(), 0}, {-2, 1e-9, 0}, {2, 1e-9, 0}, 0));
}

TEST(SphereConvexSweepDegenerate, StartingAtTheBallsCentreTheNormalIsPlusX) {
  ExpectHitAt(SweepSphereSphere(kUnitBall, Vector3::Zero(), {-1, 0, 0}, 0.1), 0, {1, 0, 0}, {1, 0, 0}, 0);
  ExpectHitAt(SweepSphereSphere(kUnitBall, Vector3::Zero(), {-1, 5, 0}, 0.1), 0, {1, 0, 0}, {1, 0, 0}, 0);
  ExpectMiss(SweepSphereSphere(kUnitBall, Vector3::Zero(), {1, 0, 0}, 0.1));
  ExpectMiss(SweepSphereSphere(kUnitBall, Vector3::Zero(), {0, 1, 0}, 0.1));
}

TEST(SphereConvexSweepDegenerate, OverflowingCoordinatesGiveNoNan) {
  for (const double big : {1e160, 1e200, 1e300}) {
    for (const auto& [a, b, r] : {std::tuple{Vector3(big, 0, 0), Vector3(-big, 0, 0), 0.5},
                                  std::tuple{Vector3(3, 0, 0), Vector3(-3, 0, 0), big},
                                  std::tuple{Vector3(big, big, 0), Vector3(-big, 1, 0), 0.0}}) {
      for (const ConvexSweepHit& hit : {SweepSphereSphere(kUnitBall, a, b, r), AdvanceAgainst(kUnitBall, a, b, r)}) {
        if (!hit.hit) continue;
        EXPECT_GE(hit.t, 0);
        EXPECT_LE(hit.t, 1);
      }
    }
  }
}

TEST(SweepSphereConvexDegenerate, AnOracleThatFindsNothingMisses) {
  int calls = 0;
  const FunctionOracle nothing{[&](const Vector3&) {
    ++calls;
    return ConvexProbe{};
  }};
  ExpectMiss(SweepSphereConvex(nothing, {3, 0, 0}, {-3, 0, 0}, 0.5));
  EXPECT_EQ(calls, 1);
  // found at the start, lost on the way
  calls = 0;
  const FunctionOracle lost{[&](const Vector3& p) {
    ++calls;
    return p.x() > 2 ? BallOracle{kUnitBall}(p) : ConvexProbe{};
  }};
  ExpectMiss(SweepSphereConvex(lost, {3, 0, 0}, {-3, 0, 0}, 0.5));
  EXPECT_EQ(calls, 2);
}

TEST(SweepSphereConvexDegenerate, AnOracleThatNeverConvergesMissesAfterTheStepBound) {
  // always 1e-9 ahead, straight against the motion: each step advances 1e-9 / 6
  int calls = 0;
  const FunctionOracle receding{[&](const Vector3& p) {
    ++calls;
    return ConvexProbe{true, 0.5 + 1e-9, p - Vector3(0.5 + 1e-9, 0, 0), Vector3::UnitX()};
  }};
  ExpectMiss(SweepSphereConvex(receding, {3, 0, 0}, {-3, 0, 0}, 0.5));
  EXPECT_EQ(calls, kMaxConvexSweepSteps);
}

TEST(SweepSphereConvexDegenerate, NanFromTheOracleMisses) {
  const FunctionOracle nan_distance{[](const Vector3&) {
    return ConvexProbe{true, kNan, Vector3::Zero(), Vector3::UnitX()};
  }};
  const FunctionOracle nan_normal{[](const Vector3& p) {
    return ConvexProbe{true, p.norm() - 1, Vector3::Zero(), Vector3::Constant(kNan)};
  }};
  ExpectMiss(SweepSphereConvex(nan_distance, {3, 0, 0}, {-3, 0, 0}, 0.5));
  ExpectMiss(SweepSphereConvex(nan_normal, {3, 0, 0}, {-3, 0, 0}, 0.5));
  ExpectMiss(SweepSphereConvex(nan_normal, {0.5, 0, 0}, {-3, 0, 0}, 0.5));
}

// ---------------------------------------------------------------------------------
// Random cases against independent oracles (fixed seeds).

// The first t in [0, 1] where gap(t) <= 0, by dense sampling then bisection, and the
// smallest sampled gap (how close a miss came); t = kInf when none is found.
struct SampledContact {
  double t = kInf;
  double min_gap = kInf;
};

template <typename Gap>
SampledContact FindFirstContactBySampling(const Gap& gap, int samples) {
  SampledContact contact;
  double previous = 0;
  for (int i = 0; i <= samples; ++i) {
    const double t = static_cast<double>(i) / samples;
    const double g = gap(t);
    contact.min_gap = std::min(contact.min_gap, g);
    if (g > 0) {
      previous = t;
      continue;
    }
    if (i == 0) {
      contact.t = 0;
      return contact;
    }
    double lo = previous, hi = t;
    for (int k = 0; k < 60; ++k) {
      const double mid = 0.5 * (lo + hi);
      (gap(mid) > 0 ? lo : hi) = mid;
    }
    contact.t = hi;
    return contact;
  }
  return contact;
}

// Checks a sweep against sampling of gap(t) = D(a + t (b - a)) - r, the sphere starting
// apart: a hit where the gap has closed to within the tolerance and never past the first
// contact, a miss where the gap never closes. A pass that comes within graze of touching
// may go either way.
template <typename Gap>
void ExpectAgreesWithSampling(const ConvexSweepHit& hit, const Gap& gap, double graze, int case_index) {
  const SampledContact oracle = FindFirstContactBySampling(gap, 4096);
  if (std::abs(oracle.min_gap) >= graze) {
    ASSERT_EQ(hit.hit, oracle.t <= 1) << case_index;
  }
  if (!hit.hit) return;
  EXPECT_GE(hit.t, 0);
  EXPECT_LE(hit.t, 1);
  EXPECT_LE(hit.t, oracle.t + 1e-12) << case_index;
  // (within the rounding of a gap computed from coordinates of magnitude 3)
  EXPECT_LE(gap(hit.t), kTolerance + 1e-13) << case_index;
  EXPECT_GE(gap(hit.t), -1e-12) << case_index;
}

TEST(SweepSphereSphere, AgreesWithSamplingOfTheGap) {
  std::mt19937_64 rng(20240612);
  std::uniform_real_distribution<double> coordinate(-3, 3), radius(0, 0.5);
  int hits = 0, misses = 0;
  for (int i = 0; i < 3000; ++i) {
    const Sphere ball{{coordinate(rng) / 3, coordinate(rng) / 3, coordinate(rng) / 3}, 0.2 + radius(rng)};
    const Vector3 a(coordinate(rng), coordinate(rng), coordinate(rng));
    const Vector3 b = i % 3 == 0 ? Vector3(ball.center + 0.5 * RandomBall(rng, 1, 1)[0])
                                 : Vector3(coordinate(rng), coordinate(rng), coordinate(rng));
    const double r = i % 5 == 0 ? 0 : radius(rng);
    const auto gap = [&](double t) { return (a + t * (b - a) - ball.center).norm() - ball.radius - r; };
    if (gap(0) < 1e-6) continue;  // start apart (touching starts: the degenerate tests)
    const ConvexSweepHit hit = SweepSphereSphere(ball, a, b, r);
    ExpectAgreesWithSampling(hit, gap, 1e-5, i);
    if (!hit.hit) {
      ++misses;
      continue;
    }
    ++hits;
    // the closed form stops exactly where the gap is the tolerance
    EXPECT_NEAR(gap(hit.t), kTolerance, 1e-12) << i;
    // the nearest point of the ball, and the normal towards the centre at contact
    const Vector3 centre = a + hit.t * (b - a);
    EXPECT_NEAR((hit.normal - (centre - ball.center).normalized()).norm(), 0, 1e-12) << i;
    EXPECT_NEAR((hit.point - (ball.center + ball.radius * hit.normal)).norm(), 0, 1e-12) << i;
  }
  EXPECT_GT(hits, 800);
  EXPECT_GT(misses, 800);
}

TEST(SweepSphereSphere, StartingInContactHitsExactlyWhenTheGapFalls) {
  std::mt19937_64 rng(612);
  std::uniform_real_distribution<double> depth(-0.3, 0.5 * kTolerance), radius(0, 0.5);
  for (int i = 0; i < 2000; ++i) {
    const double r = radius(rng);
    const Vector3 direction = RandomBall(rng, 1, 1)[0].normalized();
    const Vector3 a = (1 + r + depth(rng)) * direction;
    const Vector3 b = a + RandomBall(rng, 1, 1.0)[0];
    const ConvexSweepHit hit = SweepSphereSphere(kUnitBall, a, b, r);
    // the gap falls at the start exactly when the motion has a component towards the centre
    EXPECT_EQ(hit.hit, (b - a).dot(a) < 0) << i;
    if (hit.hit) {
      EXPECT_EQ(hit.t, 0);
    }
  }
}

// The advancement over a probe, against dense sampling of the same probe along the
// segment (the probe is the ground truth of the distance).
template <typename Oracle>
void CompareAdvancementWithSampling(const Oracle& oracle, uint64_t seed, int min_hits) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> coordinate(-2.5, 2.5), radius(0, 0.4);
  int hits = 0, misses = 0;
  for (int i = 0; i < 1500; ++i) {
    const Vector3 a(coordinate(rng), coordinate(rng), coordinate(rng));
    const Vector3 b = i % 3 == 0 ? Vector3(0.6 * RandomBall(rng, 1, 1)[0])
                                 : Vector3(coordinate(rng), coordinate(rng), coordinate(rng));
    const double r = i % 5 == 0 ? 0 : radius(rng);
    const auto gap = [&](double t) { return oracle(Vector3(a + t * (b - a))).signed_distance - r; };
    if (gap(0) < 1e-6) continue;
    const ConvexSweepHit hit = SweepSphereConvex(oracle, a, b, r);
    ExpectAgreesWithSampling(hit, gap, 1e-5, i);
    if (!hit.hit) {
      ++misses;
      continue;
    }
    ++hits;
    // the reported point and normal are the probe's at the contact
    const ConvexProbe probe = oracle(Vector3(a + hit.t * (b - a)));
    EXPECT_EQ(hit.point, probe.point) << i;
    EXPECT_EQ(hit.normal, probe.normal) << i;
    EXPECT_GT(-(b - a).dot(hit.normal), 0) << i;
  }
  EXPECT_GT(hits, min_hits);
  EXPECT_GT(misses, 100);
}

TEST(SweepSphereConvex, BoxAgreesWithSamplingOfItsProbe) {
  CompareAdvancementWithSampling(BoxOracle{Vector3(0.5, 0.75, 1)}, 31, 300);
}

TEST(SweepSphereConvex, HullAgreesWithSamplingOfItsProbe) {
  std::mt19937_64 rng(32);
  const ConvexHull hull = BuildConvexHull(RandomBall(rng, 40, 1.0));
  CompareAdvancementWithSampling(HullOracle{&hull}, 33, 300);
}

TEST(SweepSphereConvex, BallAgreesWithTheClosedForm) {
  // the iterates approach the contact from below and stop within the tolerance of it:
  // between the closed form's t (gap = tolerance) and the exact contact (gap = 0)
  std::mt19937_64 rng(34);
  std::uniform_real_distribution<double> coordinate(-3, 3), radius(0, 0.5);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Sphere ball{Vector3::Zero(), 0.3 + radius(rng)};
    const Vector3 a(coordinate(rng), coordinate(rng), coordinate(rng));
    const Vector3 b = i % 2 == 0 ? Vector3(0.5 * RandomBall(rng, 1, 1)[0])
                                 : Vector3(coordinate(rng), coordinate(rng), coordinate(rng));
    const double r = radius(rng);
    if (a.norm() - ball.radius - r < 1e-6) continue;
    const ConvexSweepHit closed = SweepSphereSphere(ball, a, b, r);
    const ConvexSweepHit advanced = AdvanceAgainst(ball, a, b, r);
    const auto gap = [&](double t) { return (a + t * (b - a)).norm() - ball.radius - r; };
    if (closed.hit != advanced.hit) {
      // only a pass that grazes the tolerance may tell them apart
      EXPECT_LT(std::abs(gap((closed.hit ? closed : advanced).t)), 2 * kTolerance) << i;
      continue;
    }
    if (!closed.hit) continue;
    ++hits;
    EXPECT_GE(advanced.t, closed.t - 1e-15) << i;
    EXPECT_LE(gap(advanced.t), kTolerance * (1 + 1e-6)) << i;
    EXPECT_GE(gap(advanced.t), -1e-13) << i;
  }
  EXPECT_GT(hits, 900);
}

}  // namespace
}  // namespace hapticd::geometry
