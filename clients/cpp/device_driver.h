#pragma once
// The interface a haptic device driver implements to be driven by hapticd-proxy.
//
// Frames and units: everything is in the scene's world frame W, SI units (m, m/s, N,
// N·m, s). A driver whose device works in its own frame (most do: a base frame B and
// millimetres) converts at this boundary, so the loop and the wire never see anything
// else.
//
// Theory of operation. The proxy loop (proxy_loop.h) calls, once per tick k at time
// t_k = k / rate_hz:
//
//     reading = driver.Read(t_k)      sample the device now
//     ... send the state, wait up to a budget for the server's command ...
//     driver.Apply(output)            render this until the next Apply
//
// Apply is called every tick, answered or not. When the server's command does not come
// within the tick, the loop's device-side watchdog (command_watchdog.h) decides the
// output: it holds the last force for a timeout (a lost packet or two must not be felt),
// then ramps the force to zero, so a device whose server has gone quiet stops pushing
// by itself. A driver therefore never sees a gap; it renders exactly what it is given.
//
// Real-time rules: Read and Apply run on the loop's thread at the device's rate; they
// must not allocate, block on I/O slower than the device's bus, throw or log.
#include <cstdint>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hapticd::proxy {

using Vector3 = Eigen::Vector3d;
using Quaternion = Eigen::Quaterniond;

// How the device and the server split the loop (hapticd.v1.DeviceType).
enum class DeviceKind {
  kImpedance,   // the device reads position and renders force
  kAdmittance,  // the device senses the person's force and moves to a commanded pose
};

// What the device is and can do: the capability handshake of OpenSession.
struct DeviceCaps {
  DeviceKind kind = DeviceKind::kImpedance;
  int degrees_of_freedom = 3;  // 3 or 6 (6-DOF devices get zero torque for now)
  double max_force = 10;       // N, > 0: the most the device renders
  double max_velocity = 2;     // m/s, > 0
  double rate_hz = 1000;       // the rate the device wants to be served at
  Vector3 start_W = Vector3::Zero();  // where the handle is now, in W
  // kg, > 0: the least mass a change of force moves (the handle's; a hand adds to it).
  // Two-port passivity's device end predicts a tick's work with it (remote::DeviceEnd).
  double handle_mass = 0.05;
};

// One sample of the device, taken by Read. Fields a device cannot sense stay at their
// defaults (identity orientation, zero velocity, zero force).
struct DeviceReading {
  Vector3 p_W = Vector3::Zero();    // handle position, m
  Quaternion q_W = Quaternion::Identity();
  Vector3 v_W = Vector3::Zero();    // m/s
  Vector3 w_W = Vector3::Zero();    // rad/s
  uint32_t buttons = 0;             // bit i: button i pressed
  Vector3 f_sensed_W = Vector3::Zero();  // admittance: the person's force at the handle, N
};

// What the device renders from one Apply to the next.
struct DeviceOutput {
  Vector3 f_W = Vector3::Zero();    // impedance: force on the handle, N
  Vector3 tau_W = Vector3::Zero();  // impedance: torque, N·m (zero for 3-DOF devices)
  Vector3 p_W = Vector3::Zero();    // admittance: where the handle must go, m
  Quaternion q_W = Quaternion::Identity();
};

class DeviceDriver {
 public:
  virtual ~DeviceDriver() = default;

  // The device's capabilities; constant over the driver's life.
  virtual DeviceCaps caps() const = 0;

  // Samples the device at time t (s, the loop's clock: k / rate_hz at tick k,
  // non-decreasing). A simulated device advances its physics to t here; a real one
  // reads its encoders and ignores t.
  virtual DeviceReading Read(double t) = 0;

  // Renders output from now until the next Apply. Impedance devices saturate the force
  // at caps().max_force themselves; a non-finite force must be rendered as zero and a
  // non-finite pose ignored (the handle stays where it was sent last).
  virtual void Apply(const DeviceOutput& output) = 0;
};

}  // namespace hapticd::proxy
