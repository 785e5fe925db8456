#include "server/sim/sim_device.h"

#include <cmath>

namespace hapticd::sim {

SimDevice::SimDevice(const Scenario& scenario)
    : mode_(scenario.session.device.mode),
      dt_(1 / scenario.rate_hz),
      resolution_(scenario.device.position_resolution),
      max_force_(scenario.session.device.max_force),
      response_time_s_(scenario.device.response_time_s),
      plant_(scenario.hand, scenario.device, dt_),
      p_W_(scenario.device.start_W),
      q_last_W_(Quantize(scenario.device.start_W)),
      target_W_(scenario.device.start_W) {}

Vector3 SimDevice::Quantize(const Vector3& p_W) const {
  // resolution 0: an exact sensor
  if (resolution_ == 0) return p_W;
  return (p_W / resolution_).array().round().matrix() * resolution_;
}

DeviceState SimDevice::Sample(double t) {
  DeviceState state;
  state.p_W = Quantize(p_W_);
  // a quantized position gives a finite-difference velocity, an exact one the true velocity
  state.v_W = resolution_ > 0 ? Vector3((state.p_W - q_last_W_) / dt_) : v_W_;
  q_last_W_ = state.p_W;
  if (mode_ == force::DeviceMode::kImpedance) {
    state.f_held_W = f_held_W_;
  } else {
    f_hand_W_ = plant_.hand().CalcForce(t, p_W_, v_W_);
    state.f_sensed_W = f_hand_W_;
  }
  return state;
}

void SimDevice::Accept(const DeviceCommand& command) {
  if (mode_ == force::DeviceMode::kAdmittance) {
    // a non-finite pose is not followed: the handle stays where it was sent last
    if (command.p_W.allFinite()) target_W_ = command.p_W;
    return;
  }
  // a non-finite force is rendered as zero; a finite one saturates at max_force
  if (!command.f_W.allFinite()) {
    f_held_W_ = Vector3::Zero();
    return;
  }
  f_held_W_ = Saturate(command.f_W);
}

void SimDevice::Advance(double t) {
  const Vector3 p_before = p_W_;
  if (mode_ == force::DeviceMode::kImpedance) {
    plant_.Step(f_held_W_, t);
    p_W_ = plant_.p_W();
    v_W_ = plant_.v_W();
    energy_j_ += f_held_W_.dot(p_W_ - p_before);
    return;
  }
  // admittance: ideal tracking of the pose command within the tick, or the servo's
  // first-order lag towards it
  p_W_ = response_time_s_ > 0 ? Vector3(target_W_ + (p_before - target_W_) * std::exp(-dt_ / response_time_s_))
                              : target_W_;
  v_W_ = (p_W_ - p_before) / dt_;
  energy_j_ += -f_hand_W_.dot(p_W_ - p_before);
}

}  // namespace hapticd::sim
