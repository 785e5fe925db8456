#pragma once
// Simulated devices behind the DeviceDriver interface, for demos, tests and benchmarks.
//
// SimDeviceDriver is the hand and device model of the scenario format
// (../shared/scenarios/FORMAT.md, server/sim/hand_device.h): a mass-spring-damper hand
// pulled towards a piecewise-linear path, rigidly holding the handle.
//   impedance:  hand and handle are one body integrated by hapticd_sim's ImpedancePlant
//               under the force the device renders (zero-order hold over each tick);
//   admittance: the handle tracks the commanded position ideally within a tick, and the
//               sensed force is the hand's spring-damper force on it.
// HeldDeviceDriver is a handle held rigidly at one point: its physics costs nothing, so
// many of them measure the network and the server, not the proxy.
#include <vector>

#include "clients/cpp/device_driver.h"
#include "server/sim/hand_device.h"
#include "server/sim/scenario.h"

namespace hapticd::proxy {

// The stroke over the default scene (floor z = 0, the box's -x face at x = 0.10): start
// 2 cm above the floor, press 5 mm into it, slide 2 cm into the box's side, lift back,
// rest; 2 s a cycle, repeated to cover seconds (> 0). The Python demo's stroke.
std::vector<sim::PathPoint> MakeStrokePath(double seconds);

// The demo's hand (0.3 kg, 300 N/m, 5 N·s/m) on the given path, and device (0.05 kg,
// 0.5 N·s/m, starting at start_W).
sim::HandSpec MakeDemoHand(std::vector<sim::PathPoint> path);
sim::DeviceSpec MakeDemoDevice(const Vector3& start_W);

class SimDeviceDriver final : public DeviceDriver {
 public:
  // caps.rate_hz (> 0) is the physics tick; caps.start_W is ignored (device.start_W is
  // where the handle starts, at rest). hand and device must be valid as the scenario
  // parser checks them (path non-empty with increasing times, masses > 0).
  SimDeviceDriver(const DeviceCaps& caps, const sim::HandSpec& hand, const sim::DeviceSpec& device);

  DeviceCaps caps() const override { return caps_; }
  // Advances the physics in whole ticks to the tick nearest t (never backwards), then
  // samples the handle. Admittance: f_sensed_W is the hand's force at the handle.
  DeviceReading Read(double t) override;
  // Impedance: saturates at caps().max_force, renders a non-finite force as zero.
  // Admittance: takes output.p_W as the next position unless it is non-finite.
  void Apply(const DeviceOutput& output) override;

  // The true handle position now, and the force being rendered (impedance).
  const Vector3& p_W() const { return p_W_; }
  const Vector3& f_held_W() const { return f_held_W_; }

 private:
  // One tick of physics from time t.
  void Step(double t);

  DeviceCaps caps_;
  double dt_;
  sim::ImpedancePlant plant_;  // impedance: hand and handle; admittance: only its hand
  int64_t ticks_ = 0;          // physics ticks done: the state is at ticks_ * dt_
  Vector3 p_W_;
  Vector3 v_W_ = Vector3::Zero();
  Vector3 f_held_W_ = Vector3::Zero();
  Vector3 target_W_;  // admittance: the newest commanded position
};

class HeldDeviceDriver final : public DeviceDriver {
 public:
  // A handle held rigidly at caps.start_W: Read always returns it at rest; Apply only
  // records the output (the hand absorbs any force).
  explicit HeldDeviceDriver(const DeviceCaps& caps) : caps_(caps) {}

  DeviceCaps caps() const override { return caps_; }
  DeviceReading Read(double) override;
  void Apply(const DeviceOutput& output) override { last_output_ = output; }

  const DeviceOutput& last_output() const { return last_output_; }

 private:
  DeviceCaps caps_;
  DeviceOutput last_output_;
};

}  // namespace hapticd::proxy
