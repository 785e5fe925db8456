#pragma once

// The simulated person and device mechanics, in the world frame W, SI units.
//
// The hand is a mass-spring-damper pulled towards a piecewise-linear path and rigidly
// coupled to the device handle. In impedance mode hand and handle move as one body of
// mass m = hand.mass + device.mass:
//   m a = K_h (path(t) - x) + B_h (path'(t) - v) - b_d v + F,
// K_h, B_h the hand's stiffness and damping, b_d the device's own damping and F the
// force the device renders, held constant over a tick (zero-order hold). The tick is
// integrated with classical Runge-Kutta (RK4) in substeps short enough (omega h <= 0.05)
// that the integrator's energy error is negligible (relative ~1e-10 per period) next to
// anything a renderer does.

#include <vector>

#include "server/sim/scenario.h"

namespace hapticd::sim {

// The path of [t, x, y, z] points: before the first point the hand wants the first
// position, after the last the last, linear in between.
class HandPath {
 public:
  // points: at least one, times strictly increasing (as the parser validates).
  explicit HandPath(std::vector<PathPoint> points);

  Vector3 PositionAt(double t) const;
  // The slope of the segment that holds t (segments are [t_i, t_{i+1}), so at a point the
  // next segment's slope); zero before the first point and from the last point on.
  Vector3 VelocityAt(double t) const;

 private:
  // i with t_i <= t < t_{i+1}; -1 before the first point; the last index from the last
  // point on.
  int SegmentAt(double t) const;

  std::vector<PathPoint> points_;
};

// The hand as a spring-damper towards its path: the force it applies to the handle.
class Hand {
 public:
  explicit Hand(const HandSpec& spec);

  // K_h (path(t) - p_W) + B_h (path'(t) - v_W), N, for the handle at p_W moving at v_W.
  Vector3 CalcForce(double t, const Vector3& p_W, const Vector3& v_W) const;
  const HandPath& path() const { return path_; }
  double mass() const { return mass_; }
  double stiffness() const { return stiffness_; }
  double damping() const { return damping_; }

 private:
  double mass_;
  double stiffness_;
  double damping_;
  HandPath path_;
};

// Substeps per tick of dt for the hand-device body: omega h <= 0.05 for both the
// spring's natural frequency sqrt(K/m) and the damping rate B/m, at least 20. Returns 0
// when more than kMaxSubsteps would be needed (the parser refuses such scenarios).
inline constexpr int kMinSubsteps = 20;
inline constexpr int kMaxSubsteps = 100'000;
int CalcSubsteps(double mass, double stiffness, double damping, double dt);

// Hand and handle in impedance mode: one rigid body driven by the hand and the held force.
class ImpedancePlant {
 public:
  // Starts at rest at device.start_W. dt > 0 is the tick; CalcSubsteps must not be 0.
  ImpedancePlant(const HandSpec& hand, const DeviceSpec& device, double dt);

  // Advances the body from time t to t + dt with f_W (N) held over the whole tick.
  void Step(const Vector3& f_W, double t);

  const Vector3& p_W() const { return p_W_; }
  const Vector3& v_W() const { return v_W_; }
  const Hand& hand() const { return hand_; }
  double mass() const { return mass_; }
  int substeps() const { return substeps_; }

 private:
  // The body's acceleration at time t in state (p, v) under the held force f.
  Vector3 CalcAcceleration(double t, const Vector3& p, const Vector3& v, const Vector3& f) const;

  Hand hand_;
  double mass_;
  double device_damping_;
  double dt_;
  int substeps_;
  Vector3 p_W_;
  Vector3 v_W_ = Vector3::Zero();
};

}  // namespace hapticd::sim
