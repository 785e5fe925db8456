#include "server/remote/deadband.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace hapticd::remote
