#pragma once

// The device end of the simulated loop: the handle, the hand holding it, the sensing
// and what the device does with a command, in impedance or admittance mode (the
// simulator's theory of operation, simulator.h, says how). The loop calls, each tick k:
// Sample(t_k), then Accept() for a command that arrived (if any), then Advance(t_k).

#include <memory>
#include <optional>

#include "server/remote/local_model.h"

#include "server/sim/hand_device.h"
#include "server/sim/scenario.h"

namespace hapticd::sim {

// What the device sends up each tick.
struct DeviceState {
  Vector3 p_W = Vector3::Zero();         // sensed (quantized) position
  Vector3 v_W = Vector3::Zero();         // sensed velocity
  Vector3 f_held_W = Vector3::Zero();    // impedance: the force held over the last tick
  Vector3 f_sensed_W = Vector3::Zero();  // admittance: the hand's force at the handle
  // remote (simulator.h): the device's channel energy in; local_model: the device's
  // proxy and the version of the model it renders
  double energy_in = 0;
  Vector3 avatar_W = Vector3::Zero();
  uint64_t model_version = 0;
};

// What the renderer sends down each tick.
struct DeviceCommand {
  Vector3 f_W = Vector3::Zero();  // impedance: the force to render
  Vector3 p_W = Vector3::Zero();  // admittance: where to move the handle
  double energy_in = 0;           // remote: the renderer's channel energy in
  std::shared_ptr<const remote::LocalModel> model;  // local_model: a new model, else null
};

class SimDevice {
 public:
  // At rest at scenario.device.start_W. The scenario must be validated.
  explicit SimDevice(const Scenario& scenario);

  // The sample at t_k (the handle at x_k).
  DeviceState Sample(double t);
  // Takes a command that has just arrived; a non-finite one is ignored (impedance: the
  // device renders zero instead).
  void Accept(const DeviceCommand& command);
  // A finite force saturated at device.max_force, as Accept renders it.
  Vector3 Saturate(const Vector3& f_W) const {
    const double norm = f_W.norm();
    return norm > max_force_ ? Vector3(f_W * (max_force_ / norm)) : f_W;
  }
  // Moves the handle over the tick [t, t + dt) and adds the tick's work to energy_j().
  void Advance(double t);

  // The true handle position and velocity now.
  const Vector3& p_W() const { return p_W_; }
  const Vector3& v_W() const { return v_W_; }
  // Impedance: the force held over this tick (after Accept). Admittance: the hand's
  // force at this tick's sample.
  const Vector3& force_W() const { return mode_ == force::DeviceMode::kImpedance ? f_held_W_ : f_hand_W_; }
  double energy_j() const { return energy_j_; }
  int substeps() const { return plant_.substeps(); }

 private:
  Vector3 Quantize(const Vector3& p_W) const;

  force::DeviceMode mode_;
  double dt_;
  double resolution_;
  double max_force_;
  double response_time_s_;  // admittance: the servo's lag (0: none)
  ImpedancePlant plant_;  // impedance: hand and handle; admittance: only its hand is used
  Vector3 p_W_;
  Vector3 v_W_ = Vector3::Zero();
  Vector3 q_last_W_;                     // the previous sensed position
  Vector3 f_held_W_ = Vector3::Zero();   // impedance: F_k
  Vector3 f_hand_W_ = Vector3::Zero();   // admittance: f_hand,k
  Vector3 target_W_;                     // admittance: the newest pose command
  double energy_j_ = 0;
};

}  // namespace hapticd::sim
