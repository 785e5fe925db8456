#pragma once

// Perceptual deadband coding (Hinterseer & Steinbach 2006; IEEE 1918.1.1): a side sends
// a new value only when it differs from the one it last sent by more than a Weber
// fraction of that value plus a small absolute floor, below which a person cannot
// tell the difference; the receiver holds (or predicts from) what it last received.

#include <limits>
#include <optional>
#include <string>

#include "server/geometry/types.h"

namespace hapticd::remote {

using geometry::Vector3;

// The floors under the Weber fraction: what is below them is not felt or seen whatever
// the fraction (about a force's and a fingertip position's absolute thresholds).
inline constexpr double kForceFloorN = 0.02;
inline constexpr double kPositionFloorM = 1e-4;
inline constexpr double kVelocityFloorMps = 2e-3;

// A session's deadband over the real channel (hapticd.v1.OpenSession's deadband
// fields): the Weber fraction, the floors (the defaults above) and the keep-alive, the
// longest a side stays silent while nothing leaves its band, so that the other side can
// tell a quiet peer from a lost one (the server's 50 ms watchdog, the device's hold).
// The simulator's channel has no keep-alive (hapticd-sim's `remote.deadband` is the
// fraction alone, with the default floors).
struct DeadbandSettings {
  double weber = 0;                            // [0, 1); 0: off, every tick sends
  double force_floor_n = kForceFloorN;         // (0, kMaxForceFloorN]
  double position_floor_m = kPositionFloorM;   // (0, kMaxPositionFloorM]
  double velocity_floor_mps = kVelocityFloorMps;  // (0, kMaxVelocityFloorMps]
  double keepalive_s = 0.01;                   // (0, kMaxKeepaliveS]
  bool on() const { return weber > 0; }
};

// The bounds ValidateDeadband holds a session's settings to.
inline constexpr double kMaxForceFloorN = 10;
inline constexpr double kMaxPositionFloorM = 0.01;
inline constexpr double kMaxVelocityFloorMps = 1;
// Half the server's watchdog timeout (force::ControlSettings, 50 ms): a keep-alive may be
// lost and the next still comes before the watchdog trips.
inline constexpr double kMaxKeepaliveS = 0.025;

// Nullopt when usable; else a message naming the field as OpenSession spells it
// ("deadband is 1.5; a Weber fraction must be in [0, 1)").
std::optional<std::string> ValidateDeadband(const DeadbandSettings& settings);

// Whether value must be sent, given the one last sent: weber 0 sends every value.
inline bool ExceedsDeadband(const Vector3& value, const Vector3& sent, double weber, double floor) {
  if (!(weber > 0)) return true;
  return (value - sent).norm() > weber * sent.norm() + floor;
}

// What a device does with a state under a deadband with a keep-alive.
enum class StateVerdict { kHold, kSend, kKeepalive };

// The device's state as the deadband sends it up: a new one when the velocity leaves
// its deadband or the receiver's prediction (the last position sent moved on at the
// last velocity sent) is off by more than the position floor.
class StateDeadband {
 public:
  // The default floors (the simulator's), or a session's.
  explicit StateDeadband(double weber) : weber_(weber) {}
  explicit StateDeadband(const DeadbandSettings& settings)
      : weber_(settings.weber),
        position_floor_m_(settings.position_floor_m),
        velocity_floor_mps_(settings.velocity_floor_mps) {}
  // Whether the state (p_W, v_W) at time t must be sent; if so, remembers it as sent.
  bool Offer(double t, const Vector3& p_W, const Vector3& v_W) {
    const bool send = !sent_any_ || ExceedsDeadband(v_W, v_sent_W_, weber_, velocity_floor_mps_) ||
                      (Predict(t) - p_W).norm() > position_floor_m_;
    if (send) Record(t, p_W, v_W);
    return send;
  }
  // Remembers a state sent whatever the deadband said (a keep-alive): the receiver
  // predicts from it.
  void Record(double t, const Vector3& p_W, const Vector3& v_W) {
    sent_any_ = true;
    t_sent_ = t;
    p_sent_W_ = p_W;
    v_sent_W_ = v_W;
  }
  // Offer with a keep-alive: a state the deadband holds back is still sent (and
  // remembered) when none has been for keepalive_s, to within half of period_s (the
  // device's tick, so that a loop's clock does not miss it by a rounding).
  StateVerdict OfferWithKeepalive(double t, const Vector3& p_W, const Vector3& v_W, double keepalive_s,
                                  double period_s) {
    if (Offer(t, p_W, v_W)) return StateVerdict::kSend;
    if (t - last_sent_t() < keepalive_s - 0.5 * period_s) return StateVerdict::kHold;
    Record(t, p_W, v_W);
    return StateVerdict::kKeepalive;
  }
  // When the last state was sent (-infinity before the first).
  double last_sent_t() const { return sent_any_ ? t_sent_ : -std::numeric_limits<double>::infinity(); }
  // What the receiver predicts at t from the last state sent.
  Vector3 Predict(double t) const { return p_sent_W_ + v_sent_W_ * (t - t_sent_); }

 private:
  double weber_;
  double position_floor_m_ = kPositionFloorM;
  double velocity_floor_mps_ = kVelocityFloorMps;
  bool sent_any_ = false;
  double t_sent_ = 0;
  Vector3 p_sent_W_ = Vector3::Zero();
  Vector3 v_sent_W_ = Vector3::Zero();
};

}  // namespace hapticd::remote
