#include "clients/cpp/command_watchdog.h"

#include <gtest/gtest.h>

namespace hapticd::proxy {
namespace {

DeviceOutput Push(double fx, const Vector3& p_W = Vector3::Zero()) {
  DeviceOutput output;
  output.f_W = Vector3(fx, 0, 0);
  output.tau_W = Vector3(0, 0, fx / 10);
  output.p_W = p_W;
  return output;
}

TEST(CommandWatchdog, HoldsThenRampsToZero) {
  CommandWatchdog watchdog(DeviceOutput{}, 0.05, 0.1);
  watchdog.Accept(Push(4, Vector3(1, 2, 3)), 1.0);
  // within the hold: as sent
  EXPECT_EQ(watchdog.Output(1.0).f_W, Vector3(4, 0, 0));
  EXPECT_EQ(watchdog.Output(1.049).f_W, Vector3(4, 0, 0));
  EXPECT_EQ(watchdog.trips(), 0u);
  // halfway down the ramp: half the force and torque, the position target kept
  const DeviceOutput half = watchdog.Output(1.10);
  EXPECT_NEAR(half.f_W.x(), 2, 1e-9);
  EXPECT_NEAR(half.tau_W.z(), 0.2, 1e-9);
  EXPECT_EQ(half.p_W, Vector3(1, 2, 3));
  // past the ramp: nothing
  EXPECT_EQ(watchdog.Output(1.16).f_W, Vector3::Zero());
  EXPECT_EQ(watchdog.Output(9.0).f_W, Vector3::Zero());
  EXPECT_EQ(watchdog.Output(9.0).p_W, Vector3(1, 2, 3));
  // one outage is one trip however long it lasts
  EXPECT_EQ(watchdog.trips(), 1u);
}

TEST(CommandWatchdog, AFreshCommandEndsTheRamp) {
  CommandWatchdog watchdog(DeviceOutput{}, 0.05, 0.1);
  watchdog.Accept(Push(4), 0.0);
  EXPECT_LT(watchdog.Output(0.12).f_W.x(), 4);
  watchdog.Accept(Push(3), 0.12);
  EXPECT_EQ(watchdog.Output(0.12).f_W, Vector3(3, 0, 0));
  // a second outage is a second trip
  watchdog.Output(0.3);
  EXPECT_EQ(watchdog.trips(), 2u);
}

TEST(CommandWatchdog, ZeroRampDropsAtOnce) {
  CommandWatchdog watchdog(DeviceOutput{}, 0.01, 0);
  watchdog.Accept(Push(5), 0.0);
  EXPECT_EQ(watchdog.Output(0.01).f_W, Vector3(5, 0, 0));
  EXPECT_EQ(watchdog.Output(0.0101).f_W, Vector3::Zero());
}

// Before any command the initial output (an admittance device's start) is held.
TEST(CommandWatchdog, StartsWithTheInitialOutput) {
  DeviceOutput initial;
  initial.p_W = Vector3(0.1, 0, 0.2);
  CommandWatchdog watchdog(initial, 0.05, 0.1);
  EXPECT_EQ(watchdog.Output(0.0).p_W, initial.p_W);
  EXPECT_EQ(watchdog.Output(1.0).p_W, initial.p_W);
  EXPECT_EQ(watchdog.Output(1.0).f_W, Vector3::Zero());
}

}  // namespace
}  // namespace hapticd::proxy
