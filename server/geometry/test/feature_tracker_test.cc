#include "server/geometry/feature_tracker.h"
#include "server/geometry/test/random_geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace hapticd::geometry {
namespace {

// A smooth rigid motion: sinusoids of random frequency and phase in position and in
// rotation angles; steps of a few millimetres and milliradians per tick.
struct Motion {
  Vector3 center, amplitude, frequency, phase, spin;
  Matrix3 rotation(double t) const {
    return (Eigen::AngleAxisd(spin.x() * t, Vector3::UnitZ()) * Eigen::AngleAxisd(spin.y() * t, Vector3::UnitY()) *
            Eigen::AngleAxisd(std::sin(spin.z() * t), Vector3::UnitX()))
        .toRotationMatrix();
  }
  Vector3 position(double t) const {
    return center + amplitude.cwiseProduct((frequency * t + phase).array().sin().matrix());
  }
};

Motion RandomMotion(std::mt19937_64& rng, const Vector3& center) {
  std::uniform_real_distribution<double> u(0, 1);
  Motion m;
  m.center = center;
  m.amplitude = Vector3(0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng));
  m.frequency = Vector3(1 + 2 * u(rng), 1 + 2 * u(rng), 1 + 2 * u(rng));
  m.phase = Vector3(6 * u(rng), 6 * u(rng), 6 * u(rng));
  m.spin = Vector3(1 + u(rng), 1 + u(rng), 1 + u(rng));
  return m;
}

// Runs the tracker and cold queries side by side; returns the total steps of each.
void RunSideBySide(const ConvexHull& a, const ConvexHull& b, std::mt19937_64& rng, int ticks, long* tracked_steps,
                   long* cold_steps) {
  FeatureTracker tracker(a, b);
  const Motion ma = RandomMotion(rng, Vector3::Zero()), mb = RandomMotion(rng, Vector3(2.2, 0, 0));
  for (int k = 0; k < ticks; ++k) {
    const double t = 1e-3 * k;
    const Matrix3 Ra = ma.rotation(t), Rb = mb.rotation(t);
    const Vector3 pa = ma.position(t), pb = mb.position(t);
    const TrackedDistance warm = tracker.Update(Ra, pa, Rb, pb);
    const TrackedDistance cold = CalcHullDistanceCold(a, Ra, pa, b, Rb, pb);
    ASSERT_EQ(warm.gjk.intersect, cold.gjk.intersect) << "tick " << k;
    EXPECT_NEAR(warm.gjk.distance, cold.gjk.distance, 1e-12) << "tick " << k;
    if (!cold.gjk.intersect && cold.gjk.distance > 1e-6) {
      EXPECT_NEAR((warm.gjk.normal - cold.gjk.normal).norm(), 0, 1e-9) << "tick " << k;
      EXPECT_NEAR((warm.gjk.point_b - warm.gjk.point_a - warm.gjk.distance * warm.gjk.normal).norm(), 0, 1e-12);
    }
    *tracked_steps += warm.steps;
    *cold_steps += cold.steps;
  }
}

TEST(FeatureTracker, SameAnswersAsColdQueriesInFewerSteps) {
  std::mt19937_64 rng(51);
  for (int n : {20, 200}) {
    long tracked = 0, cold = 0;
    for (int run = 0; run < 4; ++run) {
      const ConvexHull a = BuildConvexHull(RandomBall(rng, n, 1.0));
      const ConvexHull b = BuildConvexHull(RandomBall(rng, n, 0.8));
      RunSideBySide(a, b, rng, 1000, &tracked, &cold);
      if (testing::Test::HasFatalFailure()) return;
    }
    // coherence must pay: well under half the work of cold queries
    EXPECT_LT(2 * tracked, cold) << n << " points: tracked " << tracked << " cold " << cold;
  }
}

TEST(FeatureTracker, ResetStartsCold) {
  std::mt19937_64 rng(52);
  const ConvexHull a = BuildConvexHull(RandomBall(rng, 50, 1.0));
  const ConvexHull b = BuildConvexHull(RandomBall(rng, 50, 1.0));
  const Matrix3 I = Matrix3::Identity();
  FeatureTracker tracker(a, b);
  const TrackedDistance first = tracker.Update(I, Vector3::Zero(), I, Vector3(3, 0, 0));
  EXPECT_GT(tracker.features().size, 0);
  const TrackedDistance again = tracker.Update(I, Vector3::Zero(), I, Vector3(3, 0, 0));
  EXPECT_LT(again.steps, first.steps);
  tracker.Reset();
  EXPECT_EQ(tracker.features().size, 0);
  const TrackedDistance reset = tracker.Update(I, Vector3::Zero(), I, Vector3(3, 0, 0));
  EXPECT_EQ(reset.steps, first.steps);
  EXPECT_EQ(reset.gjk.distance, first.gjk.distance);
  EXPECT_EQ(CalcHullDistanceCold(a, I, Vector3::Zero(), b, I, Vector3(3, 0, 0)).steps, first.steps);
}

TEST(FeatureTracker, OverlapIsReportedAndTrackingRecovers) {
  std::mt19937_64 rng(53);
  const ConvexHull a = BuildConvexHull(RandomBall(rng, 30, 1.0));
  const ConvexHull b = BuildConvexHull(RandomBall(rng, 30, 1.0));
  const Matrix3 I = Matrix3::Identity();
  FeatureTracker tracker(a, b);
  // b passes through a and out the other side
  for (int k = 0; k <= 100; ++k) {
    const Vector3 pb(3 - 0.06 * k, 0.1, 0);
    const TrackedDistance warm = tracker.Update(I, Vector3::Zero(), I, pb);
    const TrackedDistance cold = CalcHullDistanceCold(a, I, Vector3::Zero(), b, I, pb);
    ASSERT_EQ(warm.gjk.intersect, cold.gjk.intersect) << k;
    EXPECT_NEAR(warm.gjk.distance, cold.gjk.distance, 1e-12) << k;
  }
}

TEST(FeatureTracker, NonFinitePoseDoesNotPoisonLaterTicks) {
  std::mt19937_64 rng(54);
  const ConvexHull a = BuildConvexHull(RandomBall(rng, 30, 1.0));
  const ConvexHull b = BuildConvexHull(RandomBall(rng, 30, 1.0));
  const Matrix3 I = Matrix3::Identity();
  FeatureTracker tracker(a, b);
  tracker.Update(I, Vector3::Zero(), I, Vector3(3, 0, 0));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  tracker.Update(I, Vector3(nan, 0, 0), I, Vector3(3, 0, 0));
  const TrackedDistance after = tracker.Update(I, Vector3::Zero(), I, Vector3(3, 0, 0));
  EXPECT_NEAR(after.gjk.distance, CalcHullDistanceCold(a, I, Vector3::Zero(), b, I, Vector3(3, 0, 0)).gjk.distance,
              1e-14);
}

}  // namespace
}  // namespace hapticd::geometry
