#pragma once

// The control layer between the ideal force F_d and the force the device renders
// (Salisbury et al. 2004): a passivity observer and controller, force and force-rate
// limits, and a watchdog. Each is a small value type, reset off the real-time path and
// stepped once per tick without allocating or throwing.

#include "server/geometry/types.h"

namespace hapticd::force {

using geometry::Vector3;

// Saturates a force to max_force (N, > 0) and its change per tick to max_force_rate·dt
// (N/s, > 0, may be infinite), keeping the direction of the saturated vector.
class ForceLimiter {
 public:
  ForceLimiter(double max_force, double max_force_rate);
  void Reset();
  // The force to render this tick; saturated() tells whether a limit acted.
  Vector3 Apply(const Vector3& f_desired, double dt);
  bool saturated() const { return saturated_; }

 private:
  double max_force_;
  double max_force_rate_;
  Vector3 f_last_ = Vector3::Zero();
  bool saturated_ = false;
};

// Passivity observer and controller (Hannaford & Ryu 2002), at the device port.
//
// The observer sums the work the rendered force has done on the device:
//   E_k = sum_j f_held_j . (x_j - x_{j-1}),
// the force the device held over each interval times the displacement in it (the
// scenario format's energy_j; positive means the rendering generated energy). The
// controller keeps the work predicted for the next interval non-positive: with v the
// device velocity extrapolated to the middle of that interval (v_k + (v_k - v_{k-1})/2),
// when E + f_d . v dt > 0 it adds a damping force -alpha v with
//   alpha = (E + f_d . v dt) / (|v|^2 dt),
// capped at max_damping (N·s/m) and at (f_d . v) / |v|^2: the controller removes the
// part of the force that pushes along the motion, down to none, but never turns it into
// a brake. Without delay that is enough to dissipate what the rendering created at
// once; behind a delayed channel, where v is stale, a stronger damper would itself
// become active. With the controller off, Apply returns f_d and only the observer runs.
class PassivityController {
 public:
  PassivityController(bool enabled, double max_damping);
  // Forgets all history; the next Observe starts a new displacement chain.
  void Reset(const Vector3& p_device);
  // One fresh device sample: position p_device and the force f_held held while moving
  // there.
  void Observe(const Vector3& p_device, const Vector3& f_held);
  // The force to render given the desired one and the device velocity.
  Vector3 Apply(const Vector3& f_desired, const Vector3& v_device, double dt);
  double observed_energy() const { return energy_; }
  bool active() const { return active_; }  // the last Apply added damping

 private:
  bool enabled_;
  double max_damping_;
  double energy_ = 0;
  Vector3 p_last_ = Vector3::Zero();
  bool has_last_ = false;
  Vector3 v_last_ = Vector3::Zero();  // the velocity the last Apply was given
  bool has_v_last_ = false;
  bool active_ = false;
};

// Ramps the force to zero when device input stops: after timeout_s (> 0) without a fresh
// input the scale falls linearly from 1 to 0 over ramp_s (> 0); a fresh input restores 1.
class Watchdog {
 public:
  Watchdog(double timeout_s, double ramp_s);
  void Reset();
  // Advances dt seconds; returns the scale (0..1) to apply to this tick's force.
  double Step(bool fresh_input, double dt);
  bool tripped() const { return silent_s_ > timeout_s_; }
  // Ticks on which the watchdog went from fed to tripped.
  unsigned long long trips() const { return trips_; }

 private:
  double timeout_s_;
  double ramp_s_;
  double silent_s_ = 0;
  unsigned long long trips_ = 0;
};

}  // namespace hapticd::force
