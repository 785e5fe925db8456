#include "clients/cpp/sim_device_driver.h"

#include <algorithm>
#include <cmath>

namespace hapticd::proxy {
namespace {

// One stroke cycle as [t, x, y, z]; see MakeStrokePath.
constexpr double kStrokeCycle[][4] = {
    {0.0, 0.05, 0.0, 0.02},
    {0.4, 0.05, 0.0, -0.005},
    {1.2, 0.12, 0.0, -0.005},
    {1.6, 0.05, 0.0, 0.02},
    {2.0, 0.05, 0.0, 0.02},
};
constexpr int kStrokePoints = sizeof kStrokeCycle / sizeof kStrokeCycle[0];

}  // namespace

std::vector<sim::PathPoint> MakeStrokePath(double seconds) {
  const double cycle_s = kStrokeCycle[kStrokePoints - 1][0];
  const int cycles = std::max(1, static_cast<int>(std::ceil(seconds / cycle_s)));
  // the first point once, then every cycle's remaining points shifted by its start
  std::vector<sim::PathPoint> path;
  path.push_back({kStrokeCycle[0][0], Vector3(kStrokeCycle[0][1], kStrokeCycle[0][2], kStrokeCycle[0][3])});
  for (int c = 0; c < cycles; ++c) {
    for (int i = 1; i < kStrokePoints; ++i) {
      const double* point = kStrokeCycle[i];
      path.push_back({point[0] + c * cycle_s, Vector3(point[1], point[2], point[3])});
    }
  }
  return path;
}

sim::HandSpec MakeDemoHand(std::vector<sim::PathPoint> path) {
  sim::HandSpec hand;
  hand.mass = 0.3;
  hand.stiffness = 300;
  hand.damping = 5;
  hand.path = std::move(path);
  return hand;
}

sim::DeviceSpec MakeDemoDevice(const Vector3& start_W) {
  sim::DeviceSpec device;
  device.mass = 0.05;
  device.damping = 0.5;
  device.start_W = start_W;
  return device;
}

SimDeviceDriver::SimDeviceDriver(const DeviceCaps& caps, const sim::HandSpec& hand,
                                 const sim::DeviceSpec& device)
    : caps_(caps),
      dt_(1 / caps.rate_hz),
      plant_(hand, device, dt_),
      p_W_(device.start_W),
      target_W_(device.start_W) {
  caps_.start_W = device.start_W;
  caps_.handle_mass = device.mass;
}

void SimDeviceDriver::Step(double t) {
  // impedance: the body moves under the hand and the held force
  if (caps_.kind == DeviceKind::kImpedance) {
    plant_.Step(f_held_W_, t);
    p_W_ = plant_.p_W();
    v_W_ = plant_.v_W();
    return;
  }
  // admittance: ideal tracking of the newest position command within the tick
  const Vector3 p_before = p_W_;
  p_W_ = target_W_;
  v_W_ = (p_W_ - p_before) / dt_;
}

DeviceReading SimDeviceDriver::Read(double t) {
  // whole ticks up to the one nearest t; a time in the past leaves the state alone
  const int64_t target_ticks = std::llround(t / dt_);
  while (ticks_ < target_ticks) {
    Step(static_cast<double>(ticks_) * dt_);
    ++ticks_;
  }
  DeviceReading reading;
  reading.p_W = p_W_;
  reading.v_W = v_W_;
  if (caps_.kind == DeviceKind::kAdmittance) {
    reading.f_sensed_W = plant_.hand().CalcForce(static_cast<double>(ticks_) * dt_, p_W_, v_W_);
  }
  return reading;
}

void SimDeviceDriver::Apply(const DeviceOutput& output) {
  if (caps_.kind == DeviceKind::kAdmittance) {
    // a non-finite pose is not followed: the handle keeps its last target
    if (output.p_W.allFinite()) target_W_ = output.p_W;
    return;
  }
  // a non-finite force is rendered as zero; a finite one saturates at max_force
  if (!output.f_W.allFinite()) {
    f_held_W_.setZero();
    return;
  }
  const double norm = output.f_W.norm();
  f_held_W_ = norm > caps_.max_force ? Vector3(output.f_W * (caps_.max_force / norm)) : output.f_W;
}

DeviceReading HeldDeviceDriver::Read(double) {
  DeviceReading reading;
  reading.p_W = caps_.start_W;
  return reading;
}

}  // namespace hapticd::proxy
