#pragma once

// Perceptual deadband coding (Hinterseer & Steinbach 2006; IEEE 1918.1.1): a side sends
// a new value only when it differs from the one it last sent by more than a Weber
// fraction of that value plus a small absolute floor, below which a person cannot
// tell the difference; the receiver holds (or predicts from) what it last received.

#include "server/geometry/types.h"

namespace hapticd::remote {

using geometry::Vector3;

// The floors under the Weber fraction: what is below them is not felt or seen whatever
// the fraction (about a force's and a fingertip position's absolute thresholds).
inline constexpr double kForceFloorN = 0.02;
inline constexpr double kPositionFloorM = 1e-4;
inline constexpr double kVelocityFloorMps = 2e-3;

// Whether value must be sent, given the one last sent: weber 0 sends every value.
inline bool ExceedsDeadband(const Vector3& value, const Vector3& sent, double weber, double floor) {
  if (!(weber > 0)) return true;
  return (value - sent).norm() > weber * sent.norm() + floor;
}

// The device's state as the deadband sends it up: a new one when the velocity leaves
// its deadband or the receiver's prediction (the last position sent moved on at the
// last velocity sent) is off by more than the position floor.
class StateDeadband {
 public:
  explicit StateDeadband(double weber) : weber_(weber) {}
  // Whether the state (p_W, v_W) at time t must be sent; if so, remembers it as sent.
  bool Offer(double t, const Vector3& p_W, const Vector3& v_W) {
    const bool send = !sent_any_ || ExceedsDeadband(v_W, v_sent_W_, weber_, kVelocityFloorMps) ||
                      (Predict(t) - p_W).norm() > kPositionFloorM;
    if (!send) return false;
    sent_any_ = true;
    t_sent_ = t;
    p_sent_W_ = p_W;
    v_sent_W_ = v_W;
    return true;
  }
  // What the receiver predicts at t from the last state sent.
  Vector3 Predict(double t) const { return p_sent_W_ + v_sent_W_ * (t - t_sent_); }

 private:
  double weber_;
  bool sent_any_ = false;
  double t_sent_ = 0;
  Vector3 p_sent_W_ = Vector3::Zero();
  Vector3 v_sent_W_ = Vector3::Zero();
};

}  // namespace hapticd::remote
