#include "clients/cpp/sim_device_driver.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hapticd::proxy {
namespace {

DeviceCaps Caps(DeviceKind kind) {
  DeviceCaps caps;
  caps.kind = kind;
  caps.max_force = 8;
  caps.rate_hz = 1000;
  return caps;
}

// A hand that moves 1 cm along +x in 0.1 s.
sim::HandSpec Hand() {
  return MakeDemoHand({{0.0, Vector3(0, 0, 0.02)}, {0.1, Vector3(0.01, 0, 0.02)}});
}

// The impedance driver is hapticd_sim's plant, tick for tick, under the force applied.
TEST(SimDeviceDriver, ImpedanceFollowsThePlant) {
  const sim::DeviceSpec device = MakeDemoDevice(Vector3(0, 0, 0.02));
  SimDeviceDriver driver(Caps(DeviceKind::kImpedance), Hand(), device);
  sim::ImpedancePlant plant(Hand(), device, 1e-3);
  DeviceOutput push;
  push.f_W = Vector3(0, 0, -1);
  for (int k = 0; k < 1000; ++k) {
    const DeviceReading reading = driver.Read(k * 1e-3);
    EXPECT_EQ(reading.p_W, plant.p_W()) << "tick " << k;
    EXPECT_EQ(reading.v_W, plant.v_W()) << "tick " << k;
    driver.Apply(push);
    plant.Step(push.f_W, k * 1e-3);
  }
  // pushed down 1 N against a 300 N/m hand: about 3.3 mm below the path
  EXPECT_NEAR(driver.p_W().z(), 0.02 - 1.0 / 300, 2e-4);
  EXPECT_NEAR(driver.p_W().x(), 0.01, 1e-3);
}

// Read advances whole ticks to the nearest one, catches up over skipped ticks and never
// goes back.
TEST(SimDeviceDriver, ReadAdvancesInWholeTicks) {
  const sim::DeviceSpec device = MakeDemoDevice(Vector3(0, 0, 0.02));
  SimDeviceDriver driver(Caps(DeviceKind::kImpedance), Hand(), device);
  sim::ImpedancePlant plant(Hand(), device, 1e-3);
  for (int k = 0; k < 5; ++k) plant.Step(Vector3::Zero(), k * 1e-3);
  EXPECT_EQ(driver.Read(0.0049).p_W, plant.p_W());
  EXPECT_EQ(driver.Read(0.001).p_W, plant.p_W());
}

TEST(SimDeviceDriver, ImpedanceSaturatesAndRefusesNonFinite) {
  SimDeviceDriver driver(Caps(DeviceKind::kImpedance), Hand(), MakeDemoDevice(Vector3::Zero()));
  DeviceOutput output;
  output.f_W = Vector3(30, 40, 0);  // 50 N
  driver.Apply(output);
  EXPECT_NEAR(driver.f_held_W().norm(), 8, 1e-12);
  EXPECT_NEAR(driver.f_held_W().x() / driver.f_held_W().y(), 0.75, 1e-12);
  output.f_W.x() = std::numeric_limits<double>::quiet_NaN();
  driver.Apply(output);
  EXPECT_EQ(driver.f_held_W(), Vector3::Zero());
}

// Admittance: the handle reaches the commanded position in one tick, and the sensed force
// is the hand's pull on it.
TEST(SimDeviceDriver, AdmittanceTracksTheCommandAndSensesTheHand) {
  const sim::HandSpec hand = Hand();
  SimDeviceDriver driver(Caps(DeviceKind::kAdmittance), hand, MakeDemoDevice(Vector3(0, 0, 0.02)));
  DeviceReading reading = driver.Read(0);
  EXPECT_EQ(reading.p_W, Vector3(0, 0, 0.02));
  DeviceOutput output;
  output.p_W = Vector3(0, 0, 0.01);
  driver.Apply(output);
  reading = driver.Read(0.001);
  EXPECT_EQ(reading.p_W, Vector3(0, 0, 0.01));
  EXPECT_NEAR(reading.v_W.z(), -10, 1e-9);
  const sim::Hand model(hand);
  EXPECT_EQ(reading.f_sensed_W, model.CalcForce(0.001, reading.p_W, reading.v_W));
  // a non-finite pose is not followed
  output.p_W.z() = std::numeric_limits<double>::infinity();
  driver.Apply(output);
  EXPECT_EQ(driver.Read(0.002).p_W, Vector3(0, 0, 0.01));
}

TEST(HeldDeviceDriver, StaysPut) {
  DeviceCaps caps = Caps(DeviceKind::kImpedance);
  caps.start_W = Vector3(0.05, 0, -0.002);
  HeldDeviceDriver driver(caps);
  DeviceOutput output;
  output.f_W = Vector3(0, 0, 4);
  driver.Apply(output);
  const DeviceReading reading = driver.Read(3.0);
  EXPECT_EQ(reading.p_W, caps.start_W);
  EXPECT_EQ(reading.v_W, Vector3::Zero());
  EXPECT_EQ(driver.last_output().f_W, Vector3(0, 0, 4));
}

// The stroke repeats its 2 s cycle to cover the run, presses 5 mm into the floor and
// reaches 2 cm into the box (its face at x = 0.10).
TEST(StrokePath, CoversTheRun) {
  const auto path = MakeStrokePath(5);
  EXPECT_EQ(path.size(), 1u + 3 * 4);
  EXPECT_GE(path.back().t, 5.0);
  double lowest = 1, farthest = 0;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(path[i].t, path[i - 1].t);
    }
    lowest = std::min(lowest, path[i].p_W.z());
    farthest = std::max(farthest, path[i].p_W.x());
  }
  EXPECT_DOUBLE_EQ(lowest, -0.005);
  EXPECT_DOUBLE_EQ(farthest, 0.12);
  EXPECT_EQ(MakeStrokePath(0.5).size(), 5u);
}

}  // namespace
}  // namespace hapticd::proxy
