#include "server/remote/deadband.h"

#include <gtest/gtest.h>

#include <cmath>

namespace hapticd::remote {
namespace {

TEST(DeadbandTest, AValueIsSentWhenItLeavesTheWeberFractionPlusTheFloor) {
  const Vector3 sent(0, 0, 2);  // 2 N: a 10% band is 0.2 N, plus the 0.02 N floor
  EXPECT_FALSE(ExceedsDeadband(Vector3(0, 0, 2.2), sent, 0.1, kForceFloorN));
  EXPECT_TRUE(ExceedsDeadband(Vector3(0, 0, 2.221), sent, 0.1, kForceFloorN));
  EXPECT_TRUE(ExceedsDeadband(Vector3(0.221, 0, 2), sent, 0.1, kForceFloorN));  // a turn counts too
  // near zero only the floor is left
  EXPECT_FALSE(ExceedsDeadband(Vector3(0, 0.019, 0), Vector3::Zero(), 0.1, kForceFloorN));
  // weber 0: everything is sent
  EXPECT_TRUE(ExceedsDeadband(sent, sent, 0, kForceFloorN));
}

TEST(DeadbandTest, StatesAreSentWhenTheVelocityChangesOrThePredictionDrifts) {
  StateDeadband deadband(0.1);
  EXPECT_TRUE(deadband.Offer(0, Vector3::Zero(), Vector3(0.1, 0, 0)));  // the first always
  // moving on as predicted: nothing to send
  for (int k = 1; k <= 100; ++k) {
    const double t = k * 0.001;
    EXPECT_FALSE(deadband.Offer(t, Vector3(0.1 * t, 0, 0), Vector3(0.1, 0, 0))) << k;
  }
  EXPECT_DOUBLE_EQ(deadband.Predict(0.2).x(), 0.02);
  // the velocity leaves its band (10% of 0.1 m/s plus 2 mm/s)
  EXPECT_FALSE(deadband.Offer(0.101, Vector3(0.0101, 0, 0), Vector3(0.111, 0, 0)));
  EXPECT_TRUE(deadband.Offer(0.102, Vector3(0.0102, 0, 0), Vector3(0.1125, 0, 0)));
  // the position drifts off the prediction by more than 0.1 mm at the same velocity
  StateDeadband drift(0.1);
  drift.Offer(0, Vector3::Zero(), Vector3::Zero());
  EXPECT_FALSE(drift.Offer(0.01, Vector3(0, 0, 0.99e-4), Vector3::Zero()));
  EXPECT_TRUE(drift.Offer(0.02, Vector3(0, 0, 1.01e-4), Vector3::Zero()));
}

TEST(DeadbandTest, WithoutAFractionEveryStateIsSent) {
  StateDeadband deadband(0);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(deadband.Offer(k * 0.001, Vector3::Zero(), Vector3::Zero()));
}

TEST(DeadbandTest, AtRestOnlyTheKeepaliveGoesUp) {
  DeadbandSettings settings;
  settings.weber = 0.1;
  settings.keepalive_s = 0.01;
  StateDeadband deadband(settings);
  int sent = 0, keepalives = 0;
  for (int k = 0; k < 1000; ++k) {
    switch (deadband.OfferWithKeepalive(k * 0.001, Vector3(0, 0, 0.1), Vector3::Zero(), 0.01, 0.001)) {
      case StateVerdict::kSend: ++sent; break;
      case StateVerdict::kKeepalive: ++keepalives; break;
      case StateVerdict::kHold: break;
    }
  }
  // the first, then one every 10 ticks (10 ms): 90% saved
  EXPECT_EQ(sent, 1);
  EXPECT_EQ(keepalives, 99);
  // a keep-alive restarts the prediction: a move right after it is measured from it
  EXPECT_EQ(deadband.OfferWithKeepalive(0.995, Vector3(0, 0, 0.1 + 0.99e-4), Vector3::Zero(), 0.01, 0.001),
            StateVerdict::kHold);
}

TEST(DeadbandTest, ASessionsFloorsReplaceTheDefaults) {
  DeadbandSettings settings;
  settings.weber = 0.1;
  settings.position_floor_m = 1e-3;
  settings.velocity_floor_mps = 0.05;
  StateDeadband deadband(settings);
  deadband.Offer(0, Vector3::Zero(), Vector3::Zero());
  // 0.5 mm off and 40 mm/s: within these floors (not the defaults)
  EXPECT_FALSE(deadband.Offer(0.001, Vector3(0, 0, 5e-4), Vector3(0, 0, 0.04)));
  EXPECT_TRUE(deadband.Offer(0.002, Vector3(0, 0, 1.1e-3), Vector3(0, 0, 0.04)));
}

TEST(DeadbandTest, BadSettingsAreNamedWithTheirBounds) {
  EXPECT_FALSE(ValidateDeadband(DeadbandSettings{}).has_value());
  const auto error = [](auto change) {
    DeadbandSettings settings;
    settings.weber = 0.1;
    change(settings);
    return ValidateDeadband(settings).value_or("");
  };
  EXPECT_EQ(error([](DeadbandSettings& s) { s.weber = 1; }),
            "deadband is 1; a Weber fraction must be in [0, 1) (0: off)");
  EXPECT_EQ(error([](DeadbandSettings& s) { s.weber = std::nan(""); }),
            "deadband is nan; a Weber fraction must be in [0, 1) (0: off)");
  EXPECT_EQ(error([](DeadbandSettings& s) { s.force_floor_n = -1; }),
            "deadband_force_floor is -1; it must be in (0, 10]");
  EXPECT_EQ(error([](DeadbandSettings& s) { s.position_floor_m = 0.02; }),
            "deadband_position_floor is 0.02; it must be in (0, 0.01]");
  EXPECT_EQ(error([](DeadbandSettings& s) { s.velocity_floor_mps = 0; }),
            "deadband_velocity_floor is 0; it must be in (0, 1]");
  EXPECT_EQ(error([](DeadbandSettings& s) { s.keepalive_s = 0.05; }),
            "keepalive_s is 0.05; it must be in (0, 0.025] (half the server's 50 ms watchdog at most)");
}

}  // namespace
}  // namespace hapticd::remote
