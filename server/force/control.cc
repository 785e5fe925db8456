#include "server/force/control.h"

#include <algorithm>
#include <cmath>

namespace hapticd::force {
namespace {

// Below this squared speed ((m/s)^2) the device is taken as still: a damper would need
// an unbounded coefficient to dissipate anything, so the controller leaves the force.
constexpr double kStillSpeedSquared = 1e-18;

// f scaled to magnitude `magnitude`, computed without overflow for huge finite f.
// Precondition: f finite and nonzero.
Vector3 ScaleToMagnitude(const Vector3& f, double magnitude) {
  const Vector3 unit_ish = f / f.cwiseAbs().maxCoeff();
  return unit_ish * (magnitude / unit_ish.norm());
}

}  // namespace

ForceLimiter::ForceLimiter(double max_force, double max_force_rate)
    : max_force_(max_force), max_force_rate_(max_force_rate) {}

void ForceLimiter::Reset() {
  f_last_ = Vector3::Zero();
  saturated_ = false;
}

Vector3 ForceLimiter::Apply(const Vector3& f_desired, double dt) {
  saturated_ = false;
  // a non-finite request renders as zero (the caller counts it)
  Vector3 target = f_desired.allFinite() ? f_desired : Vector3::Zero();

  // saturate the magnitude, keeping the direction (an overflowing norm is also too big)
  if (target.norm() > max_force_) {
    target = ScaleToMagnitude(target, max_force_);
    saturated_ = true;
  }

  // limit the change per tick; an infinite rate never acts, a bad dt allows no change
  if (std::isfinite(max_force_rate_)) {
    const double max_step = (dt > 0 && std::isfinite(dt)) ? max_force_rate_ * dt : 0.0;
    const Vector3 step = target - f_last_;
    const double step_size = step.norm();
    if (step_size > max_step) {
      // both ends lie in the max_force ball, so every point between them does too
      target = f_last_ + step * (max_step / step_size);
      saturated_ = true;
    }
  }

  f_last_ = target;
  return target;
}

PassivityController::PassivityController(bool enabled, double max_damping)
    : enabled_(enabled), max_damping_(max_damping) {}

void PassivityController::Reset(const Vector3& p_device) {
  // The force held before the reset is not this rendering's work: the first Observe
  // after a reset only records its position.
  energy_ = 0;
  p_last_ = p_device;
  has_last_ = false;
  has_v_last_ = false;
  active_ = false;
}

void PassivityController::Observe(const Vector3& p_device, const Vector3& f_held) {
  // a non-finite sample is skipped; the next finite one restarts the displacement
  if (!p_device.allFinite()) {
    has_last_ = false;
    return;
  }
  // a non-finite held force did no work we can account for; keep the position only
  if (has_last_ && f_held.allFinite()) {
    const double work = f_held.dot(p_device - p_last_);
    if (std::isfinite(work)) energy_ += work;
  }
  p_last_ = p_device;
  has_last_ = true;
}

// Theory of operation (Hannaford & Ryu 2002, one step ahead): the observer's E is the
// work the rendering has done so far. Rendering f over the next interval adds about
// f . v dt with v the velocity in the middle of that interval, extrapolated from the
// last two samples (v_k + (v_k - v_{k-1}) / 2: the sampled v_k alone misses the
// F a dt^2 / 2 a stiff wall adds while it accelerates the device), so the predicted
// total is E + f_d . v dt. When that is positive, the damper
// -alpha v removes alpha |v|^2 dt, and alpha = (E + f_d . v dt) / (|v|^2 dt) brings the
// prediction back to zero. The caps keep the damper itself stable: at most max_damping,
// and at most what cancels the force's component along v (no braking force of its own,
// which a stale v behind a delayed channel would turn active).
Vector3 PassivityController::Apply(const Vector3& f_desired, const Vector3& v_device,
                                   double dt) {
  active_ = false;
  if (!enabled_) return f_desired;
  // non-finite input: no damping can be computed; pass f_desired on for the limiter
  if (!f_desired.allFinite() || !v_device.allFinite() || !(dt > 0) || !std::isfinite(dt))
    return f_desired;

  const Vector3 v = has_v_last_ ? Vector3(v_device + 0.5 * (v_device - v_last_)) : v_device;
  v_last_ = v_device;
  has_v_last_ = true;
  const double speed_squared = v.squaredNorm();
  const double predicted = energy_ + f_desired.dot(v) * dt;
  // passive as predicted, or the device is still: nothing to dissipate
  if (!(predicted > 0) || !(speed_squared > kStillSpeedSquared)) return f_desired;

  const double alpha = std::min({max_damping_, predicted / (speed_squared * dt),
                                 std::max(0.0, f_desired.dot(v)) / speed_squared});
  // an infinite cap with an overflowing ratio: no finite damping to add
  if (!std::isfinite(alpha)) return f_desired;
  active_ = true;
  return f_desired - alpha * v;
}

Watchdog::Watchdog(double timeout_s, double ramp_s) : timeout_s_(timeout_s), ramp_s_(ramp_s) {}

void Watchdog::Reset() {
  silent_s_ = 0;
  trips_ = 0;
}

double Watchdog::Step(bool fresh_input, double dt) {
  // a fresh input feeds the watchdog
  if (fresh_input) {
    silent_s_ = 0;
    return 1;
  }
  // count the silence; a NaN or negative dt adds none, an infinite one trips at once
  const bool was_tripped = tripped();
  if (dt > 0) silent_s_ += dt;
  if (!was_tripped && tripped()) ++trips_;

  // full force until the timeout, then a linear ramp to zero over ramp_s
  if (!tripped()) return 1;
  const double scale = 1 - (silent_s_ - timeout_s_) / ramp_s_;
  return std::clamp(scale, 0.0, 1.0);
}

}  // namespace hapticd::force
