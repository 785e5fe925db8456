#include "server/force/control.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace hapticd::force {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------
// ForceLimiter

TEST(ForceLimiterTest, WithinLimitsPassesThroughExactly) {
  ForceLimiter limiter(10, 1000);
  const Vector3 f(0.3, -0.4, 0.2);
  EXPECT_EQ(limiter.Apply(f, 0.001), f);
  EXPECT_FALSE(limiter.saturated());
}

TEST(ForceLimiterTest, MagnitudeSaturationKeepsDirection) {
  ForceLimiter limiter(10, kInf);
  const Vector3 f = limiter.Apply(Vector3(0, 30, -40), 0.001);
  EXPECT_TRUE(limiter.saturated());
  EXPECT_NEAR(f.y(), 6, 1e-12);
  EXPECT_NEAR(f.z(), -8, 1e-12);
  EXPECT_EQ(f.x(), 0);
  // back within the limit: no saturation, the request itself
  EXPECT_EQ(limiter.Apply(Vector3(1, 2, 3), 0.001), Vector3(1, 2, 3));
  EXPECT_FALSE(limiter.saturated());
}

// A finite force whose norm overflows still saturates along its direction.
TEST(ForceLimiterTest, HugeFiniteForceSaturatesWithoutOverflow) {
  ForceLimiter limiter(10, kInf);
  const Vector3 f = limiter.Apply(Vector3(1e300, -1e300, 0), 0.001);
  EXPECT_TRUE(limiter.saturated());
  ASSERT_TRUE(f.allFinite());
  EXPECT_NEAR(f.x(), 10 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(f.y(), -10 / std::sqrt(2.0), 1e-12);
}

// 1000 N/s at 1 ms: at most 1 N of change per tick, along the way to the target.
TEST(ForceLimiterTest, RateLimitWalksTowardsTheTarget) {
  ForceLimiter limiter(100, 1000);
  const Vector3 target(3, 4, 0);
  for (int tick = 1; tick <= 4; ++tick) {
    const Vector3 f = limiter.Apply(target, 0.001);
    EXPECT_TRUE(limiter.saturated()) << tick;
    EXPECT_NEAR((f - target * (tick / 5.0)).norm(), 0, 1e-12) << tick;
  }
  EXPECT_NEAR((limiter.Apply(target, 0.001) - target).norm(), 0, 1e-12);
  // arrived: the request passes through unchanged
  EXPECT_EQ(limiter.Apply(target, 0.001), target);
  EXPECT_FALSE(limiter.saturated());
}

// Both limits at once: the rate limit walks towards the magnitude-saturated target.
TEST(ForceLimiterTest, RateLimitAimsAtTheSaturatedTarget) {
  ForceLimiter limiter(10, 2000);
  Vector3 f;
  for (int tick = 0; tick < 4; ++tick) f = limiter.Apply(Vector3(0, 0, -300), 0.001);
  EXPECT_TRUE(limiter.saturated());
  EXPECT_NEAR((f - Vector3(0, 0, -8)).norm(), 0, 1e-12);
  for (int tick = 0; tick < 2; ++tick) f = limiter.Apply(Vector3(0, 0, -300), 0.001);
  EXPECT_NEAR((f - Vector3(0, 0, -10)).norm(), 0, 1e-12);
  EXPECT_TRUE(limiter.saturated());  // the magnitude limit still acts
}

// Random requests against an independent oracle: saturate by normalizing, then clamp
// the step with its unit direction. Each request is a random step from the last output,
// so that neither limit, either one or both act.
TEST(ForceLimiterTest, RandomRequestsAgreeWithOracle) {
  std::mt19937_64 rng(20240601);
  std::uniform_real_distribution<double> component(-5, 5);
  std::uniform_real_distribution<double> period(0.0001, 0.004);
  const double max_force = 12;
  const double max_rate = 3000;
  ForceLimiter limiter(max_force, max_rate);
  Vector3 last = Vector3::Zero();
  int saturations = 0;
  int magnitude_saturations = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vector3 request = last + Vector3(component(rng), component(rng), component(rng));
    const double dt = period(rng);
    const Vector3 f = limiter.Apply(request, dt);

    // oracle
    Vector3 target = request;
    bool saturated = false;
    if (request.norm() > max_force) {
      target = request.normalized() * max_force;
      saturated = true;
    }
    const Vector3 step = target - last;
    if (step.norm() > max_rate * dt) {
      target = last + step.normalized() * (max_rate * dt);
      saturated = true;
    }

    ASSERT_NEAR((f - target).norm(), 0, 1e-9) << i;
    ASSERT_EQ(limiter.saturated(), saturated) << i;
    ASSERT_LE(f.norm(), max_force * (1 + 1e-12)) << i;
    ASSERT_LE((f - last).norm(), max_rate * dt * (1 + 1e-12)) << i;
    magnitude_saturations += request.norm() > max_force;
    saturations += saturated;
    last = f;
  }
  // the sample exercises every outcome
  EXPECT_GT(magnitude_saturations, 1000);
  EXPECT_GT(saturations - magnitude_saturations, 1000);
  EXPECT_LT(saturations, 19000);
}

// NaN and infinite requests render as zero (rate-limited) and leave the state usable.
TEST(ForceLimiterTest, NonFiniteRequestDoesNotPoisonTheState) {
  ForceLimiter limiter(10, 1000);
  for (int tick = 0; tick < 5; ++tick) limiter.Apply(Vector3(5, 0, 0), 0.001);
  // towards zero by at most 1 N
  Vector3 f = limiter.Apply(Vector3(kNaN, 0, 0), 0.001);
  EXPECT_NEAR((f - Vector3(4, 0, 0)).norm(), 0, 1e-12);
  f = limiter.Apply(Vector3(0, kInf, 0), 0.001);
  EXPECT_NEAR((f - Vector3(3, 0, 0)).norm(), 0, 1e-12);
  // a finite request afterwards works from the last output
  f = limiter.Apply(Vector3(3, 0.5, 0), 0.001);
  EXPECT_EQ(f, Vector3(3, 0.5, 0));
  EXPECT_FALSE(limiter.saturated());

  // without a rate limit a NaN request is zero at once
  ForceLimiter unlimited(10, kInf);
  unlimited.Apply(Vector3(5, 5, 5), 0.001);
  EXPECT_EQ(unlimited.Apply(Vector3(kNaN, kNaN, kNaN), 0.001), Vector3::Zero());
  EXPECT_FALSE(unlimited.saturated());
}

// With a finite rate, a zero, negative or NaN period allows no change; an infinite rate
// never limits.
TEST(ForceLimiterTest, BadPeriodHoldsTheLastForce) {
  ForceLimiter limiter(10, 1000);
  limiter.Apply(Vector3(0.5, 0, 0), 0.001);
  for (double dt : {0.0, -0.001, kNaN, kInf}) {
    EXPECT_EQ(limiter.Apply(Vector3(2, 0, 0), dt), Vector3(0.5, 0, 0)) << dt;
    EXPECT_TRUE(limiter.saturated()) << dt;
  }
  ForceLimiter unlimited(10, kInf);
  for (double dt : {0.0, -0.001, kNaN, kInf})
    EXPECT_EQ(unlimited.Apply(Vector3(2, 0, 0), dt), Vector3(2, 0, 0)) << dt;
}

TEST(ForceLimiterTest, ResetForgetsTheLastForce) {
  ForceLimiter limiter(10, 1000);
  for (int tick = 0; tick < 5; ++tick) limiter.Apply(Vector3(0, 5, 0), 0.001);
  limiter.Reset();
  EXPECT_FALSE(limiter.saturated());
  EXPECT_EQ(limiter.Apply(Vector3(0, 0.5, 0), 0.001), Vector3(0, 0.5, 0));
}

// ---------------------------------------------------------------------------------------
// PassivityController: exact cases

// The first sample after a reset only records where the device is.
TEST(PassivityControllerTest, ObserverSumsHeldForceTimesDisplacement) {
  PassivityController controller(false, 100);
  controller.Reset(Vector3(0, 0, 0));
  controller.Observe(Vector3(1, 0, 0), Vector3(5, 5, 5));
  EXPECT_EQ(controller.observed_energy(), 0);
  // (2, -1, 0.5) . ((1.5, 1, 2) - (1, 0, 0)) = 1 - 1 + 1 = 1
  controller.Observe(Vector3(1.5, 1, 2), Vector3(2, -1, 0.5));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 1);
  // a force opposing the motion absorbs: -3 * 0.5
  controller.Observe(Vector3(2, 1, 2), Vector3(-3, 7, 0));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), -0.5);
  // a reset starts over
  controller.Reset(Vector3(2, 1, 2));
  EXPECT_EQ(controller.observed_energy(), 0);
  controller.Observe(Vector3(3, 1, 2), Vector3(1, 0, 0));
  EXPECT_EQ(controller.observed_energy(), 0);
}

// Drives the observer to the energy e (J) with one displacement along x.
void PrimeEnergy(PassivityController& controller, double e) {
  controller.Reset(Vector3::Zero());
  controller.Observe(Vector3::Zero(), Vector3::Zero());
  controller.Observe(Vector3(0.001, 0, 0), Vector3(e / 0.001, 0, 0));
}

TEST(PassivityControllerTest, DisabledControllerOnlyObserves) {
  PassivityController controller(false, 100);
  PrimeEnergy(controller, 0.01);
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 0.01);
  const Vector3 f_d(1, 2, 3);
  EXPECT_EQ(controller.Apply(f_d, Vector3(0.5, 0, 0), 0.001), f_d);
  EXPECT_FALSE(controller.active());
}

// E + f_d . v dt <= 0: nothing to dissipate.
TEST(PassivityControllerTest, PassivePredictionLeavesTheForce) {
  PassivityController controller(true, 100);
  PrimeEnergy(controller, -0.001);
  // 1 N along a 0.5 m/s motion adds 0.0005 J: still -0.0005
  EXPECT_EQ(controller.Apply(Vector3(1, 0, 0), Vector3(0.5, 0, 0), 0.001), Vector3(1, 0, 0));
  EXPECT_FALSE(controller.active());
  // a prediction of exactly zero is passive too
  PrimeEnergy(controller, 0.0005);
  EXPECT_EQ(controller.Apply(Vector3(-1, 0, 0), Vector3(0.5, 0, 0), 0.001), Vector3(-1, 0, 0));
  EXPECT_FALSE(controller.active());
}

// E = -0.0001 J, f_d . v dt = 0.0003 J: alpha = 0.0002 / (0.25 * 0.001) = 0.8 N·s/m (below
// the cap (f_d . v) / |v|^2 = 1.2), and the predicted work of the result over the next
// tick brings E exactly to zero.
TEST(PassivityControllerTest, DampingCancelsThePredictedEnergy) {
  PassivityController controller(true, 100);
  PrimeEnergy(controller, -0.0001);
  const Vector3 v(0.3, 0.4, 0);
  const Vector3 f_d(1, 0, 0.5);
  const Vector3 f = controller.Apply(f_d, v, 0.001);
  EXPECT_TRUE(controller.active());
  EXPECT_NEAR((f - (f_d - 0.8 * v)).norm(), 0, 1e-9);
  EXPECT_NEAR(-0.0001 + f.dot(v) * 0.001, 0, 1e-15);
  // Apply does not change the observed energy
  EXPECT_DOUBLE_EQ(controller.observed_energy(), -0.0001);
}

// With energy already generated (E = 0.01 J) the controller removes the force's whole
// component along the motion (alpha = (f_d . v) / |v|^2 = 1.2), and no more: it never
// brakes on its own.
TEST(PassivityControllerTest, DampingNeverExceedsTheForceAlongTheMotion) {
  PassivityController controller(true, 100);
  PrimeEnergy(controller, 0.01);
  const Vector3 v(0.3, 0.4, 0);
  const Vector3 f = controller.Apply(Vector3(1, 0, 0.5), v, 0.001);
  EXPECT_TRUE(controller.active());
  EXPECT_NEAR((f - (Vector3(1, 0, 0.5) - 1.2 * v)).norm(), 0, 1e-12);
  EXPECT_NEAR(f.dot(v), 0, 1e-15);
}

TEST(PassivityControllerTest, DampingIsCappedAtMaxDamping) {
  PassivityController controller(true, 0.5);
  PrimeEnergy(controller, 0.01);
  const Vector3 v(0.3, 0.4, 0);
  const Vector3 f = controller.Apply(Vector3(1, 0, 0.5), v, 0.001);
  EXPECT_TRUE(controller.active());
  EXPECT_NEAR((f - (Vector3(1, 0, 0.5) - 0.5 * v)).norm(), 0, 1e-12);
}

// A still device cannot be damped: the force passes unchanged.
TEST(PassivityControllerTest, StillDeviceIsLeftAlone) {
  PassivityController controller(true, 1e9);
  PrimeEnergy(controller, 0.01);
  for (const Vector3& v : {Vector3(0, 0, 0), Vector3(1e-12, 0, 0)}) {
    EXPECT_EQ(controller.Apply(Vector3(1, 2, 3), v, 0.001), Vector3(1, 2, 3));
    EXPECT_FALSE(controller.active());
  }
}

// Non-finite samples are skipped, non-finite Apply input passes f_d on undamped; the
// energy stays finite and the controller keeps working afterwards.
TEST(PassivityControllerTest, NonFiniteInputDoesNotPoisonTheEnergy) {
  PassivityController controller(true, 100);
  PrimeEnergy(controller, 0.01);
  // a NaN position is skipped and breaks the displacement chain
  controller.Observe(Vector3(kNaN, 0, 0), Vector3(1, 0, 0));
  controller.Observe(Vector3(5, 0, 0), Vector3(1, 0, 0));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 0.01);
  // a NaN or infinite held force does no counted work but the position is kept
  controller.Observe(Vector3(6, 0, 0), Vector3(kNaN, 0, 0));
  controller.Observe(Vector3(7, 0, 0), Vector3(kInf, 0, 0));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 0.01);
  controller.Observe(Vector3(8, 0, 0), Vector3(0.001, 0, 0));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 0.011);
  // a finite force times a finite displacement that overflows is skipped
  controller.Observe(Vector3(1e300, 0, 0), Vector3(1e300, 0, 0));
  EXPECT_DOUBLE_EQ(controller.observed_energy(), 0.011);

  // Apply: NaN velocity, force or period: f_d unchanged, inactive
  EXPECT_EQ(controller.Apply(Vector3(1, 0, 0), Vector3(kNaN, 0, 0), 0.001), Vector3(1, 0, 0));
  EXPECT_FALSE(controller.active());
  EXPECT_EQ(controller.Apply(Vector3(1, 0, 0), Vector3(1, 0, 0), kNaN), Vector3(1, 0, 0));
  EXPECT_EQ(controller.Apply(Vector3(1, 0, 0), Vector3(1, 0, 0), 0), Vector3(1, 0, 0));
  EXPECT_FALSE(controller.Apply(Vector3(kNaN, 0, 0), Vector3(1, 0, 0), 0.001).allFinite());
  EXPECT_FALSE(controller.active());
  EXPECT_TRUE(std::isfinite(controller.observed_energy()));
  // still works
  EXPECT_FALSE(controller.Apply(Vector3(1, 0, 0), Vector3(1, 0, 0), 0.001).isApprox(
      Vector3(1, 0, 0)));
  EXPECT_TRUE(controller.active());
}

// ---------------------------------------------------------------------------------------
// Watchdog (periods in powers of two so every sum is exact)

TEST(WatchdogTest, RampsToZeroAfterTheTimeout) {
  const double dt = 1.0 / 64;
  Watchdog watchdog(4 * dt, 8 * dt);
  EXPECT_EQ(watchdog.Step(true, dt), 1);
  // silent up to the timeout: full force
  for (int tick = 1; tick <= 4; ++tick) {
    EXPECT_EQ(watchdog.Step(false, dt), 1) << tick;
    EXPECT_FALSE(watchdog.tripped());
  }
  // then linear to zero over 8 ticks, one trip
  for (int tick = 1; tick <= 8; ++tick) {
    EXPECT_EQ(watchdog.Step(false, dt), 1 - tick / 8.0) << tick;
    EXPECT_TRUE(watchdog.tripped());
  }
  EXPECT_EQ(watchdog.Step(false, dt), 0);
  EXPECT_EQ(watchdog.trips(), 1u);
  // a fresh input restores full force at once; the next silence is a second trip
  EXPECT_EQ(watchdog.Step(true, dt), 1);
  EXPECT_FALSE(watchdog.tripped());
  for (int tick = 0; tick < 5; ++tick) watchdog.Step(false, dt);
  EXPECT_EQ(watchdog.trips(), 2u);
  EXPECT_EQ(watchdog.Step(false, dt), 0.75);
  watchdog.Reset();
  EXPECT_EQ(watchdog.trips(), 0u);
  EXPECT_FALSE(watchdog.tripped());
  EXPECT_EQ(watchdog.Step(false, dt), 1);
}

// Intermittent input that never stays away past the timeout never trips.
TEST(WatchdogTest, ShortGapsNeverTrip) {
  Watchdog watchdog(0.05, 0.1);
  for (int tick = 0; tick < 10000; ++tick)
    EXPECT_EQ(watchdog.Step(tick % 40 == 0, 0.001), 1) << tick;
  EXPECT_EQ(watchdog.trips(), 0u);
}

// A NaN or negative period adds no silence; an infinite one trips at once to zero.
TEST(WatchdogTest, BadPeriods) {
  Watchdog watchdog(0.05, 0.1);
  for (double dt : {kNaN, -1.0, 0.0}) {
    EXPECT_EQ(watchdog.Step(false, dt), 1);
    EXPECT_FALSE(watchdog.tripped());
  }
  EXPECT_EQ(watchdog.Step(false, kInf), 0);
  EXPECT_TRUE(watchdog.tripped());
  EXPECT_EQ(watchdog.Step(false, 0.001), 0);
  EXPECT_EQ(watchdog.trips(), 1u);
}

// ---------------------------------------------------------------------------------------
// Closed loop: a 1-D device pressed into a sampled virtual wall.
//
// The device (with the hand on it) is a mass m with viscous damping b, pushed towards -x
// by a constant hand force and, for x < 0, pushed back by a wall rendered as F = -K x.
// The renderer samples x every T and holds its force over the tick (zero-order hold);
// between samples the continuous dynamics are integrated with 20 RK4 substeps. The work
// the wall does on the device is W = sum F_k (x_{k+1} - x_k).
//
// With U(x) = K min(x, 0)^2 / 2 (F = -U', U' Lipschitz with constant K),
//   F_k dx_k = -(U(x_{k+1}) - U(x_k)) + [U(x_{k+1}) - U(x_k) - U'(x_k) dx_k]
// and the bracket is at most K dx_k^2 / 2 <= (K T / 2) \int_k v^2 dt. So
//   W <= U(x_0) - U(x_N) + (K T / 2) \int v^2 dt:
// the sampled wall alone can generate energy, at most K T / 2 times \int v^2, and the
// device's own damper dissipates D = b \int v^2. With b > K T / 2 (Colgate & Schenkel)
// W - D <= 0 for every run: wall plus device is passive and the contact rings down. With
// b < K T / 2 the wall pumps energy in and the device chatters on the wall.

constexpr double kMass = 0.35;          // kg, device plus hand
constexpr double kDeviceDamping = 0.5;  // N·s/m
constexpr double kHandForce = -2;       // N, pressing into the wall
constexpr double kPeriod = 0.001;       // s
constexpr int kTicks = 2000;            // 2 s
constexpr double kStart = 0.001;        // m above the wall, at rest

struct WallRun {
  double work_first_second = 0;   // W over [0, 1) s, J
  double work = 0;                // W over [0, 2) s, J
  double dissipated = 0;          // D over [0, 2) s, J
  double max_observed = -kInf;    // the largest running W at any tick, J
  double peak_speed_first = 0;    // max |v| over [0, 1) s, m/s
  double peak_speed_second = 0;   // max |v| over [1, 2) s, m/s
  double final_energy_seen = 0;   // the controller's observed energy at the last tick
  double work_before_last = 0;    // W up to the last sample (what the observer can see)
  int activations = 0;
};

WallRun RunWall(double stiffness, bool passivity) {
  PassivityController controller(passivity, 1000);
  double x = kStart;
  double v = 0;
  Vector3 f_held = Vector3::Zero();
  controller.Reset(Vector3(x, 0, 0));
  WallRun run;
  for (int k = 0; k < kTicks; ++k) {
    // sample, observe, render
    controller.Observe(Vector3(x, 0, 0), f_held);
    run.final_energy_seen = controller.observed_energy();
    run.work_before_last = run.work;
    const double f_wall = x < 0 ? -stiffness * x : 0;
    const double f = controller.Apply(Vector3(f_wall, 0, 0), Vector3(v, 0, 0),
                                      kPeriod).x();
    run.activations += controller.active();

    // the device moves under the held force over one tick
    const double x_sample = x;
    const double h = kPeriod / 20;
    const auto accel = [&](double vel) { return (kHandForce + f - kDeviceDamping * vel) / kMass; };
    for (int s = 0; s < 20; ++s) {
      const double a1 = accel(v);
      const double a2 = accel(v + h / 2 * a1);
      const double a3 = accel(v + h / 2 * a2);
      const double a4 = accel(v + h * a3);
      const double v_end = v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
      // Simpson on v^2 for the damper's dissipation
      const double v_mid = v + h / 2 * a2;
      run.dissipated += kDeviceDamping * h / 6 * (v * v + 4 * v_mid * v_mid + v_end * v_end);
      x += h / 6 * (v + 2 * (v + h / 2 * a1) + 2 * (v + h / 2 * a2) + (v + h * a3));
      v = v_end;
    }

    // account
    run.work += f * (x - x_sample);
    run.max_observed = std::max(run.max_observed, run.work);
    if (k < kTicks / 2) {
      run.work_first_second = run.work;
      run.peak_speed_first = std::max(run.peak_speed_first, std::abs(v));
    } else {
      run.peak_speed_second = std::max(run.peak_speed_second, std::abs(v));
    }
    f_held = Vector3(f, 0, 0);
  }
  return run;
}

// K = 500 N/m: K T / 2 = 0.25 < b = 0.5. The wall itself still does net positive work
// here (about +3.8 mJ: the ZOH spring generates up to K T / 2 \int v^2, and the contact
// ends at a phase where little energy sits in the spring), but never more than the
// device damper dissipates, and the contact rings down.
TEST(ClosedLoopWallTest, SoftWallIsPassiveWithTheDeviceDamping) {
  const WallRun run = RunWall(500, false);
  EXPECT_LT(run.work - run.dissipated, 0);
  // the bound above, with its margin: W <= D / 2 - U(x_N) <= D / 2
  EXPECT_LE(run.work, run.dissipated / 2 + 1e-9);
  EXPECT_LT(run.peak_speed_second, 0.8 * run.peak_speed_first);
}

// K = 20000 N/m: K T / 2 = 10 >> b. The wall pumps energy into the device, more than its
// damper dissipates, and keeps doing so: it chatters on the wall.
TEST(ClosedLoopWallTest, StiffWallGeneratesEnergyWithoutControl) {
  const WallRun run = RunWall(20000, false);
  EXPECT_GT(run.work_first_second, 0.01);                   // about 0.05 J
  EXPECT_GT(run.work - run.work_first_second, 0.05);        // about +0.12 J more
  EXPECT_GT(run.work - run.dissipated, 0.01);
  EXPECT_GT(run.peak_speed_second, run.peak_speed_first);   // about 0.76 vs 0.11 m/s
}

// The same stiff wall with the passivity controller: the observed work stays at or
// below zero (up to a one-tick prediction error), and the bouncing decays instead of
// growing. (It decays at the rate of the device's own damping: the controller removes
// only what the wall generated, not the impact energy.)
//
// The controller predicts the next tick's work as F . v T with v extrapolated to the
// middle of the tick. The device moves x_{k+1} - x_k = v T + a T^2 / 2 + ...; with the
// sampled v alone, the work would be underpredicted by F a T^2 / 2 ~ 3e-5 J while the
// wall accelerates the device out (a ~ 10 m/s^2, F ~ 6 N). The extrapolation is
// second-order accurate, and only the jump in acceleration at impact is left.
TEST(ClosedLoopWallTest, PassivityControllerKeepsTheStiffWallPassive) {
  const WallRun uncontrolled = RunWall(20000, false);
  const WallRun run = RunWall(20000, true);
  EXPECT_GT(run.activations, 100);
  // the observer saw exactly the work the device received (all but the last tick)
  EXPECT_NEAR(run.final_energy_seen, run.work_before_last, 1e-12);
  // at or below zero at the end (energy is stored in the compressed wall)
  EXPECT_LE(run.work, 1e-9);
  // the running work never builds up: at most a few microjoules at an impact, against
  // 0.17 J uncontrolled
  EXPECT_LE(run.max_observed, 5e-6);
  EXPECT_GT(uncontrolled.work, 0.1);
  // the bouncing decays (peak speed about 0.117 then 0.066 m/s; uncontrolled 0.76)
  EXPECT_LT(run.peak_speed_second, 0.7 * run.peak_speed_first);
  EXPECT_LT(run.peak_speed_second, uncontrolled.peak_speed_second / 5);
}

// On the soft wall the observer still sees the sampled spring's own generation (it
// watches the wall's port, not the device's damper), and the controller removes it.
TEST(ClosedLoopWallTest, PassivityControllerOnSoftWall) {
  const WallRun run = RunWall(500, true);
  EXPECT_GT(run.activations, 0);
  EXPECT_LE(run.max_observed, 5e-6);
  EXPECT_LT(run.work, 0);
}

}  // namespace
}  // namespace hapticd::force
