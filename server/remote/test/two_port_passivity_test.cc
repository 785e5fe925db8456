#include "server/remote/two_port_passivity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace hapticd::remote {
namespace {

TEST(ChannelPortTest, ObserverSplitsWorkIntoInAndOut) {
  ChannelPort port(false);
  port.ReceiveOtherIn(0.6);
  port.Observe(0.5);
  port.Observe(-0.2);
  port.Observe(std::nan(""));  // ignored
  EXPECT_DOUBLE_EQ(port.energy().out, 0.5);
  EXPECT_DOUBLE_EQ(port.energy().in, 0.2);
  port.ReceiveOtherIn(0.1);  // an older message: in never decreases
  EXPECT_DOUBLE_EQ(port.other_in(), 0.6);
  EXPECT_DOUBLE_EQ(port.available(), 0.1);
  EXPECT_EQ(port.owed(), 0);
  EXPECT_EQ(port.repaid(), 0);
}

// The leak the maps found on the rising plate (direct + TDPA, 0.5 m/s, up to +68 uJ): a
// tick's work overshot its allowance, and the brake's work that followed went on as in,
// which the other end let out again, so the overshoot stayed in the channel for good.
// Energy in while owing repays the debt and is not passed on.
TEST(ChannelPortTest, EnergyInWhileOwingRepaysTheDebtAndIsNotPassedOn) {
  ChannelPort port(true, 0.05);
  port.ReceiveOtherIn(1e-3);
  port.Observe(1.2e-3);  // a prediction fell short: 0.2 mJ too much left
  EXPECT_NEAR(port.owed(), 2e-4, 1e-18);
  EXPECT_NEAR(port.available(), -2e-4, 1e-18);
  port.Observe(-5e-5);  // the brake takes some back: all of it repays
  EXPECT_EQ(port.energy().in, 0);
  EXPECT_NEAR(port.owed(), 1.5e-4, 1e-18);
  port.Observe(-3e-4);  // the rest of the debt, then 0.15 mJ passed on
  EXPECT_EQ(port.owed(), 0);
  EXPECT_NEAR(port.repaid(), 2e-4, 1e-18);
  EXPECT_NEAR(port.energy().in, 1.5e-4, 1e-18);
  EXPECT_NEAR(port.energy().out, 1e-3, 1e-18);
  // the net the observer measured is unchanged: 1.2 mJ out, 0.35 mJ in
  EXPECT_NEAR(port.energy().out - port.energy().in, 1.2e-3 - 3.5e-4, 1e-18);
  // the other end lets out all that was passed on and had let in the 1 mJ: the channel
  // generated nothing
  const double channel = (port.energy().out - port.energy().in) + (port.energy().in - port.other_in());
  EXPECT_LE(channel, 1e-18);
}

TEST(ChannelPortTest, WithoutControlNothingIsLimited) {
  ChannelPort port(false);
  const Vector3 f(1, 0, 0), v(1, 0, 0);
  EXPECT_EQ(port.LimitForce(f, v, 0.001), f);
  EXPECT_EQ(port.LimitStep(Vector3(0, 0, -1e-3), {Vector3(0, 0, 5), Vector3::UnitZ(), 0, 1000}, 0.001),
            Vector3(0, 0, -1e-3));
  EXPECT_FALSE(port.active());
}

TEST(ChannelPortTest, ForceAlongTheMotionIsCutToTheAllowance) {
  ChannelPort port(true);
  port.ReceiveOtherIn(0.001);  // 1 mJ may leave here
  const Vector3 f(3, 4, 0), v(2, 0, 0);
  // 3 N x 2 m/s x 1 ms = 6 mJ asked, 1 mJ allowed
  const Vector3 limited = port.LimitForce(f, v, 0.001);
  EXPECT_TRUE(port.active());
  EXPECT_NEAR(limited.dot(v) * 0.001, 0.001, 1e-15);
  EXPECT_DOUBLE_EQ(limited.y(), 4);  // across the motion: untouched
  // nothing allowed: the part along the motion goes, and no brake replaces it
  port.Observe(0.002);
  const Vector3 none = port.LimitForce(f, v, 0.001);
  EXPECT_NEAR(none.x(), 0, 1e-12);
  // a force against the motion puts energy in: never limited
  EXPECT_EQ(port.LimitForce(-f, v, 0.001), -f);
}

TEST(ChannelPortTest, StepIntoTheEnvironmentIsCutSoThatItsSpringWorkFits) {
  ChannelPort port(true);
  port.ReceiveOtherIn(1e-4);
  const Vector3 f_env(0, 0, 2);  // the environment pushes up with 2 N
  const double k = 1000;
  const Vector3 step(1e-3, 0, -1e-3);  // 1 mm across, 1 mm down into it
  const Vector3 limited = port.LimitStep(step, {f_env, Vector3::UnitZ(), 0, k}, 0.001);
  EXPECT_TRUE(port.active());
  EXPECT_DOUBLE_EQ(limited.x(), 1e-3);  // across: kept
  const double a = -limited.z();
  EXPECT_GT(a, 0);
  // the work as the observer counts it: the force at the step's end times the step
  EXPECT_NEAR((2 + k * a) * a, 1e-4, 1e-15);
  // out of the environment: never limited
  EXPECT_EQ(port.LimitStep(-step, {f_env, Vector3::UnitZ(), 0, k}, 0.001), -step);
  // not touching: the step may reach the surface (short of it by a micrometre, outside
  // the proxies' contact skin), and press only what the allowance pays
  ChannelPort empty(true);
  const Vector3 down(0, 0, -1e-3);
  EXPECT_EQ(empty.LimitStep(down, {Vector3::Zero(), Vector3::UnitZ(), 2e-3, k}, 0.001), down);
  EXPECT_NEAR(empty.LimitStep(down, {Vector3::Zero(), Vector3::UnitZ(), 4e-4, k}, 0.001).z(), -(4e-4 - 1e-6), 1e-15);
}

// A renderer end that owes (a prediction fell short) backs its step out of the spring
// just far enough that the spring's push repays the debt (the brake of its end): the
// work at the step's end, K b^2 - force b, is the debt taken back.
TEST(ChannelPortTest, OwingTheEnvironmentEndBacksOutUntilThePushRepays) {
  const double k = 1000;
  ChannelPort port(true);
  port.Observe(1e-4);  // let out 0.1 mJ, nothing allowed
  // 2 mm in: 2 N pushing up; the device deeper still (a step down asked)
  const Vector3 f_env(0, 0, 2);
  const Vector3 step = port.LimitStep(Vector3(1e-4, 0, -1e-3), {f_env, Vector3::UnitZ(), 0, k}, 0.001);
  EXPECT_TRUE(port.active());
  EXPECT_DOUBLE_EQ(step.x(), 1e-4);  // across: kept
  const double back = step.z();
  ASSERT_GT(back, 0);
  port.Observe(-(2 - k * back) * back);
  EXPECT_NEAR(port.owed(), 0, 1e-15);
  EXPECT_EQ(port.energy().in, 0);
  // not owing any more: the step into the spring is cut to nothing, the rest kept
  EXPECT_NEAR(port.LimitStep(Vector3(0, 0, -1e-3), {Vector3(0, 0, 2 - k * back), Vector3::UnitZ(), 0, k}, 0.001).z(),
              0, 1e-15);
  // a debt larger than any backing out repays (force^2 / 4K): the most is taken
  ChannelPort deep(true);
  deep.Observe(1);
  EXPECT_NEAR(deep.LimitStep(Vector3::Zero(), {f_env, Vector3::UnitZ(), 0, k}, 0.001).z(), 2 / (2 * k), 1e-15);
  // nothing pushes (free space): nothing to take back, the step is kept
  EXPECT_EQ(deep.LimitStep(Vector3(0, 0, 1e-3), {Vector3::Zero(), Vector3::UnitZ(), 0.01, k}, 0.001),
            Vector3(0, 0, 1e-3));
}

// A spring wall behind a channel end, pressed and released at random: the end never
// lets out more than it was allowed, whatever the allowance did meanwhile.
TEST(ChannelPortTest, EnvironmentEndOfASpringNeverLetsOutMoreThanAllowed) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> step_size(-2e-4, 2e-4);
  const double k = 5000;
  ChannelPort port(true);
  double x = 0, allowed = 0;  // the avatar's height; the wall is z < 0
  for (int tick = 0; tick < 20000; ++tick) {
    if (tick % 50 == 0) {
      allowed += 1e-5;
      port.ReceiveOtherIn(allowed);
    }
    const Vector3 f_env(0, 0, x < 0 ? -k * x : 0);
    const double target = step_size(random) - 1e-5;  // drifts into the wall
    const Vector3 step = port.LimitStep(Vector3(0, 0, target), {f_env, Vector3::UnitZ(), std::max(x, 0.0), k}, 0.001);
    const double next = x + step.z();
    // the work as the renderer counts it: the force at the step's end times the step
    port.Observe(-(next < 0 ? -k * next : 0.0) * step.z());
    x = next;
    ASSERT_LE(port.energy().out, port.other_in() + 1e-12) << "tick " << tick;
    ASSERT_EQ(port.repaid(), 0) << "tick " << tick;  // the spring's work is predicted exactly
  }
}

}  // namespace
}  // namespace hapticd::remote
