#pragma once

// Two-port time-domain passivity across a delayed channel (Ryu, Artigas et al. 2011):
// an energy observer at each end of the channel, the energy each end has let into the
// channel travelling with its messages, and a variable damper at each end that keeps
// the energy the channel lets out there at or below what the other end has let in.
// Then out_device + out_renderer <= in_renderer + in_device, whatever the delay, jitter
// or loss: the channel cannot generate energy.
//
// Theory of operation. Each end observes, per tick, the work the channel did on its
// load: at the device, the rendered force F over the handle's displacement dx
// (F . dx); at the renderer, the force the avatar's position input pushed into the
// virtual environment, -F_env . dx_avatar (F_env: the environment's force on the
// avatar). Positive work is energy leaving the channel (added to out), negative work
// energy entering it (added to in). Each message carries the sender's in; the
// receiver keeps the largest it has seen (in never decreases, so a late or lost
// message only makes the bound stricter), and may let out at most other_in - out.
// - The device end (force out, LimitForce) adds a damper on the handle's own predicted
//   velocity so that the tick's predicted work fits what is left; where more has left
//   than was allowed (a prediction was short) the damper brakes to take the excess
//   back, up to mass / dt (a damper on the handle's own velocity is passive; the cap
//   keeps the discrete damper stable).
// - The renderer end (position into the environment, LimitStep) shortens the avatar's
//   step into the environment: the step's component against the environment's force
//   (or, not touching, into the nearest surface past its gap) is cut until the
//   predicted work fits, the rest of the step is kept. The avatar then
//   lags the device (the position drift); it catches up by itself whenever energy
//   allows, since each step aims at the newest device position. Where more has left
//   than was allowed, the step backs out of the environment far enough for the
//   environment's push to take the excess back (its brake).
// Both predict a tick's work before it happens, as the observers will count it (the
// environment end: its force at the step's end times the step; the device end: the
// force over the handle's displacement, which a change of force itself drives). A
// prediction can fall short (the hand accelerates the handle within the tick, a loop
// stalls with a force held): then out > other_in, the end owes the difference. Energy
// that enters an end while it owes repays the debt first: it is kept in the channel
// (dissipated: out goes down by it) and not passed on as in, so the other end cannot
// let it out again. Hence, at every instant,
//   channel energy = (out_d - in_d) + (out_r - in_r) <= owed_d + owed_r,
// since out_d <= other_in_d + owed_d <= in_r + owed_d, and the same at the renderer:
// the channel generates no energy but what an end still owes, and each end's brake
// drives what it owes to zero (the device's whenever the handle moves, the renderer's
// whenever the environment pushes the avatar).

#include <algorithm>

#include "server/geometry/types.h"

namespace hapticd::remote {

using geometry::Vector3;

// The energy that has crossed one end of the channel, J: out - in is the net work the
// channel did on the load there, as the observer measured it.
struct PortEnergy {
  // entered the channel here (the load did work on it) and was passed on: what the other
  // end may let out. Non-decreasing.
  double in = 0;
  // left the channel here (the channel did work on the load), less what entered here to
  // repay an excess (ChannelPort::repaid()).
  double out = 0;
};

// The environment about the avatar, for predicting a step's work: a spring along the
// nearest surface's normal.
struct EnvironmentNear {
  Vector3 f_W = Vector3::Zero();  // its last force on the avatar (zero: not touching)
  Vector3 normal_W = Vector3::UnitZ();  // the nearest surface's outward normal
  double gap = 0;        // m: how far that surface is (when not touching; negative: that deep inside)
  double stiffness = 0;  // N/m, >= 0: a bound on its stiffness (0: no surface near)
  double damping = 0;    // N·s/m, >= 0: its damping along the normal
  double approach = 0;   // m, >= 0: how far that surface moves towards the avatar in the tick
};

class ChannelPort {
 public:
  // control: whether the damper acts (false: only the observer runs). The device end
  // needs the mass (kg, > 0) its force moves at least, the handle's: a change of force
  // moves it within the tick, which its velocity alone would not predict.
  explicit ChannelPort(bool control, double mass = 0);
  void Reset();

  // The work (J) the channel did on this end's load over the last tick. Under control,
  // negative work (energy in) repays what this end owes first; only the rest is passed
  // on as in (without control the observer only counts: in and out are the raw sums).
  void Observe(double work);
  // The other end's in, as its newest message carries it.
  void ReceiveOtherIn(double other_in);

  // Impedance end: the force to hold over the next tick (dt s), given the desired one
  // and the load's velocity extrapolated to the middle of the tick at its last
  // acceleration (the change from the last force held adds to that).
  Vector3 LimitForce(const Vector3& f_desired, const Vector3& v_mid, double dt);
  // Environment end: the avatar's step over the next tick (dt s; from its last
  // position towards the newest device position), given what the environment is about
  // the avatar. The avatar's velocity is then the step over dt. While this end owes,
  // the step backs out of a pushing environment far enough to repay it (at most to
  // where the push would vanish).
  Vector3 LimitStep(const Vector3& step, const EnvironmentNear& near, double dt);

  const PortEnergy& energy() const { return energy_; }
  double other_in() const { return other_in_; }
  // What this end may still let out (negative: more has left than was allowed).
  double available() const { return other_in_ - energy_.out; }
  // How much more has left than was allowed (>= 0): what this end owes the channel
  // (under control; without it, what it would owe).
  double owed() const { return std::max(energy_.out - other_in_, 0.0); }
  // The energy that entered here to repay what this end owed, J (kept in the channel).
  double repaid() const { return repaid_; }
  // The last Limit call changed its input.
  bool active() const { return active_; }
  // Whether the damper acts (the constructor's control).
  bool control() const { return control_; }

 private:
  bool control_;
  double mass_;
  PortEnergy energy_;
  Vector3 f_last_W_ = Vector3::Zero();  // the last force LimitForce returned
  double other_in_ = 0;
  double repaid_ = 0;
  bool active_ = false;
};

}  // namespace hapticd::remote
