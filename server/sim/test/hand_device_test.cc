#include "server/sim/hand_device.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace hapticd::sim {
namespace {

HandSpec MakeHand(double mass, double stiffness, double damping, std::vector<PathPoint> path) {
  HandSpec hand;
  hand.mass = mass;
  hand.stiffness = stiffness;
  hand.damping = damping;
  hand.path = std::move(path);
  return hand;
}

DeviceSpec MakeDevice(double mass, double damping, const Vector3& start_W) {
  DeviceSpec device;
  device.mass = mass;
  device.damping = damping;
  device.start_W = start_W;
  return device;
}

TEST(HandPath, IsPiecewiseLinearAndStandsStillOutside) {
  const HandPath path({{1.0, Vector3(0, 0, 0)}, {2.0, Vector3(1, 0, 0)}, {4.0, Vector3(1, 2, 0)}});
  EXPECT_EQ(path.PositionAt(-5), Vector3(0, 0, 0));
  EXPECT_EQ(path.PositionAt(1.0), Vector3(0, 0, 0));
  EXPECT_EQ(path.PositionAt(1.5), Vector3(0.5, 0, 0));
  EXPECT_EQ(path.PositionAt(2.0), Vector3(1, 0, 0));
  EXPECT_EQ(path.PositionAt(3.0), Vector3(1, 1, 0));
  EXPECT_EQ(path.PositionAt(9.0), Vector3(1, 2, 0));
  EXPECT_EQ(path.VelocityAt(0.5), Vector3::Zero());
  // at a point, the next segment's slope
  EXPECT_EQ(path.VelocityAt(1.0), Vector3(1, 0, 0));
  EXPECT_EQ(path.VelocityAt(2.0), Vector3(0, 1, 0));
  EXPECT_EQ(path.VelocityAt(4.0), Vector3::Zero());
  // a single point is a fixed target
  const HandPath still({{0.0, Vector3(1, 2, 3)}});
  EXPECT_EQ(still.PositionAt(-1), Vector3(1, 2, 3));
  EXPECT_EQ(still.PositionAt(7), Vector3(1, 2, 3));
  EXPECT_EQ(still.VelocityAt(0), Vector3::Zero());
}

TEST(CalcSubsteps, KeepsOmegaHSmallWithinBounds) {
  // a soft hand: the minimum
  EXPECT_EQ(CalcSubsteps(0.35, 300, 5.5, 1e-3), kMinSubsteps);
  // stiff or heavily damped: the fewest substeps with omega h <= 0.05
  for (const double omega : {3e3, 1e4, 7.7e4}) {
    for (const int n : {CalcSubsteps(1.0, omega * omega, 0, 1e-3), CalcSubsteps(1.0, 0, omega, 1e-3)}) {
      EXPECT_LE(omega * 1e-3 / n, 0.05 * (1 + 1e-12)) << omega;
      EXPECT_GT(omega * 1e-3 / (n - 1), 0.05) << omega;
    }
  }
  // beyond kMaxSubsteps: refused
  EXPECT_EQ(CalcSubsteps(1.0, 1e30, 0, 1e-3), 0);
  EXPECT_EQ(CalcSubsteps(1.0, 0, 1e12, 1e-3), 0);
}

// The free response of an underdamped mass-spring-damper released at rest from x0,
// against its closed form: x(t) - p = e^(-a t) (A cos(wd t) + (a A / wd) sin(wd t)).
TEST(ImpedancePlant, FreeResponseMatchesTheClosedForm) {
  const Vector3 p(0.01, -0.02, 0.03);
  const Vector3 x0(0.05, 0.0, -0.01);
  const HandSpec hand = MakeHand(0.3, 300, 5, {{0.0, p}});
  const DeviceSpec device = MakeDevice(0.05, 0.5, x0);
  const double dt = 1e-3;
  ImpedancePlant plant(hand, device, dt);

  const double m = 0.35;
  const double a = (5 + 0.5) / (2 * m);
  const double wd = std::sqrt(300 / m - a * a);
  const Vector3 amplitude = x0 - p;
  for (int k = 0; k < 2000; ++k) {
    plant.Step(Vector3::Zero(), k * dt);
    const double t = (k + 1) * dt;
    const double decay = std::exp(-a * t);
    const Vector3 x = p + decay * (std::cos(wd * t) + a / wd * std::sin(wd * t)) * amplitude;
    // v = d/dt of the above = -decay (a^2 / wd + wd) sin(wd t) A
    const Vector3 v = -decay * (a * a / wd + wd) * std::sin(wd * t) * amplitude;
    ASSERT_LT((plant.p_W() - x).norm(), 1e-11) << "tick " << k;
    ASSERT_LT((plant.v_W() - v).norm(), 1e-9) << "tick " << k;
  }
}

// Following a ramp at speed u, the body settles where the hand's spring balances the
// device's damping: x = path(t) - b_d u / K_h (the hand's damping acts on v - u = 0).
TEST(ImpedancePlant, FollowsARampWithTheDeviceDampingLag) {
  const double u = 0.1;
  const HandSpec hand = MakeHand(0.3, 300, 5, {{0.0, Vector3::Zero()}, {10.0, Vector3(10 * u, 0, 0)}});
  const DeviceSpec device = MakeDevice(0.05, 0.5, Vector3::Zero());
  ImpedancePlant plant(hand, device, 1e-3);
  for (int k = 0; k < 5000; ++k) plant.Step(Vector3::Zero(), k * 1e-3);
  EXPECT_NEAR(plant.p_W().x(), 5 * u - 0.5 * u / 300, 1e-10);
  EXPECT_NEAR(plant.v_W().x(), u, 1e-10);
  EXPECT_EQ(plant.p_W().y(), 0);
}

// Without damping, the work of the held force is the change of the body's mechanical
// energy, tick by tick: F_k . (x_k+1 - x_k) = dE. This is the energy_j identity.
TEST(ImpedancePlant, HeldForceWorkEqualsTheChangeOfMechanicalEnergy) {
  const Vector3 p(0, 0, 0.01);
  const HandSpec hand = MakeHand(0.3, 300, 0, {{0.0, p}});
  const DeviceSpec device = MakeDevice(0.05, 0, Vector3(0, 0, 0.02));
  const double dt = 1e-3;
  ImpedancePlant plant(hand, device, dt);
  auto energy = [&] {
    return 0.5 * plant.mass() * plant.v_W().squaredNorm() + 0.5 * 300 * (plant.p_W() - p).squaredNorm();
  };
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> force(-3, 3);
  const double e0 = energy();
  double work = 0;
  for (int k = 0; k < 3000; ++k) {
    const Vector3 f(force(random), force(random), force(random));
    const Vector3 before = plant.p_W();
    const double e_before = energy();
    plant.Step(f, k * dt);
    const double tick_work = f.dot(plant.p_W() - before);
    ASSERT_NEAR(energy() - e_before, tick_work, 1e-12) << "tick " << k;
    work += tick_work;
  }
  EXPECT_NEAR(energy() - e0, work, 1e-10);
  EXPECT_GT(std::abs(work), 1e-3);  // the forces did real work
}

}  // namespace
}  // namespace hapticd::sim
