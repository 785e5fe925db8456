#include "server/remote/two_port_passivity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace hapticd::remote {
namespace {

TEST(ChannelPortTest, ObserverSplitsWorkIntoInAndOut) {
  ChannelPort port(false);
  port.Observe(0.5);
  port.Observe(-0.2);
  port.Observe(std::nan(""));  // ignored
  EXPECT_DOUBLE_EQ(port.energy().out, 0.5);
  EXPECT_DOUBLE_EQ(port.energy().in, 0.2);
  port.ReceiveOtherIn(0.3);
  port.ReceiveOtherIn(0.1);  // an older message: in never decreases
  EXPECT_DOUBLE_EQ(port.other_in(), 0.3);
  EXPECT_DOUBLE_EQ(port.available(), -0.2);
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
  }
}

}  // namespace
}  // namespace hapticd::remote
