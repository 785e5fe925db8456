#pragma once

// The two ends of a delayed channel under two-port time-domain passivity
// (two_port_passivity.h), as the simulator, hapticd's realtime thread and the device
// proxy all run them: one ChannelPort each, and what each end must remember between
// ticks to observe its tick's work and to predict the next one's.
//
//   device end (hapticd-proxy, sim)                 renderer end (hapticd, sim)
//   Sample(p, v, f_held): observe f_held . dp        Step(scene, target): the avatar input's
//   Limit(f): the force to hold (LimitForce)   <-->  step towards the newest device position,
//   energy().in travels up with the states           cut by LimitStep; Observe(output, step)
//   ReceiveOtherIn(command's in)                     energy().in travels down with the commands
//
// Without control both ends only observe: the channel's energy is reported in every mode
// (a run without TDPA shows what the controller would have to remove). Everything is
// held by value: no allocation, no lock, no throw (real-time safe).
//
// With a local model (local_model.h) the device renders its force from geometry it
// holds, not from the renderer's: the channel carries the scene, not power, and the
// only place energy can be generated on the way to the hand is that local rendering (a
// model change moving a surface under the avatar, the sampled wall itself). So the
// device's port is a one-port on it (the passivity observer and controller of Hannaford
// & Ryu 2002): it observes the force's work relative to the surface it pushes from
// (F . (dx - v_surface dt): a kinematic object's motion is the scene's, an ideal
// source, not generated), and may let out what the hand put into it, its own in. The
// renderer's end neither observes nor holds its avatar back (its session only shadows
// the device, to cut the models about it): its energies stay zero, so the channel's
// energy is the device port's out - in.

#include "server/force/render_session.h"
#include "server/remote/two_port_passivity.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::remote {

// A force as a device renders it: saturated at max_force (N), zero when not finite.
inline Vector3 SaturateForce(const Vector3& f_W, double max_force) {
  if (!f_W.allFinite()) return Vector3::Zero();
  const double norm = f_W.norm();
  return norm > max_force ? Vector3(f_W * (max_force / norm)) : f_W;
}

// On a local model the device's port lets out what came in less this much (J): a tick
// whose prediction falls short (the hand accelerating the handle within it, a limit
// cycle's turn) lets out more than allowed, which the port owes until energy in repays
// it; the reserve covers such a debt as it comes (the largest in the simulator's maps,
// a wall of 10,000 N/m in a limit cycle: 3.2 uJ), so that the channel's energy stays at
// or below zero in every run, not only once the debt is repaid.
inline constexpr double kLocalModelReserveJ = 10e-6;

// The device's end. mass: kg, > 0 (the handle's, the least a change of force moves).
// local_model: the device renders from its own local model (a one-port, above).
class DeviceEnd {
 public:
  DeviceEnd(bool control, double mass, bool local_model = false) : port_(control, mass), local_model_(local_model) {}
  // Off the real-time path or between ticks: the handle at p_W, at rest; energies zero.
  void Reset(const Vector3& p_W);

  // A sample at the start of a tick: the handle at p_W moving at v_W, after f_W was held
  // for held_s s since the last sample (its work over the displacement is observed; on
  // a local model relative to the surface's motion over held_s). Remembers the velocity
  // extrapolated to the middle of the coming tick (v + (v - v_last) / 2).
  void Sample(const Vector3& p_W, const Vector3& v_W, const Vector3& f_W, double held_s = 0);
  // The newest in the renderer end has reported (a message's); on a local model the
  // port's credit is its own in, and this is ignored.
  void ReceiveOtherIn(double other_in) {
    if (!local_model_) port_.ReceiveOtherIn(other_in);
  }
  // On a local model, each tick: the velocity of the surface the force held over the
  // coming tick pushes from (force::TickOutput::v_surface_W; non-finite: zero), which the
  // port predicts and observes relative to.
  void SetSurfaceVelocity(const Vector3& v_surface_W) {
    v_surface_W_ = v_surface_W.allFinite() ? v_surface_W : Vector3::Zero();
  }
  // The force to hold over the coming tick of dt s, for f_W (already saturated to what
  // the device renders): itself without control, else through the port's LimitForce.
  Vector3 Limit(const Vector3& f_W, double dt);
  // The force a device whose limit is max_force (N, > 0) holds over the coming tick of
  // dt s for the force f_W it was asked for: saturated (a non-finite one: zero), through
  // Limit, and saturated again (the brake may add to it), so that the force held is the
  // force rendered, as the observer counts it. hapticd-proxy and hapticd-sim both hold this.
  Vector3 LimitSaturated(const Vector3& f_W, double max_force, double dt) {
    return SaturateForce(Limit(SaturateForce(f_W, max_force), dt), max_force);
  }

  bool local_model() const { return local_model_; }
  const ChannelPort& port() const { return port_; }
  const PortEnergy& energy() const { return port_.energy(); }

 private:
  ChannelPort port_;
  bool local_model_;
  Vector3 p_last_W_ = Vector3::Zero();
  Vector3 v_last_W_ = Vector3::Zero();
  Vector3 v_mid_W_ = Vector3::Zero();
  Vector3 v_surface_W_ = Vector3::Zero();  // local model: SetSurfaceVelocity's
};

// What the renderer end knows of the environment about the avatar input, for its
// port's LimitStep: touching (a force last tick), the object the avatar touched, its
// stiffness and damping and its motion at the avatar; else the surface nearest the
// input within the step's reach (a sphere of radius r, the avatar's). dt: the tick, s.
EnvironmentNear FindEnvironmentNear(const scene::SceneSnapshot& scene, const Vector3& f_env_W, int touched,
                                    const Vector3& avatar_W, const Vector3& p_input_W, double r,
                                    const Vector3& step, double dt);

// The renderer's end: its port, the avatar input it has given the session (behind the
// newest device position while the port holds it back: the position drift), and the
// session's last force, touched object and avatar.
class RendererEnd {
 public:
  // observes: false for a local model's session, whose input no hand pushes (above).
  explicit RendererEnd(bool control, bool observes = true) : port_(control), observes_(observes) {}
  void Reset(const Vector3& start_W);

  void ReceiveOtherIn(double other_in) { port_.ReceiveOtherIn(other_in); }
  // The avatar input's step over the coming tick of dt s towards target_W (the newest
  // device position), r the avatar's radius. Without control: the whole way. With it:
  // through LimitStep; the rest is the drift, caught up on later ticks as energy
  // allows (each step aims at the newest target). Advances input_W() by the step.
  Vector3 Step(const scene::SceneSnapshot& scene, const Vector3& target_W, double r, double dt);
  // After the session's tick on input_W(): the work its input did on the environment
  // over step (-F . step, impedance; when it observes), and the environment it leaves
  // (Remember).
  void Observe(const force::TickOutput& output, const Vector3& step);
  // The environment the session's tick leaves: its force, touched object and avatar.
  void Remember(const force::TickOutput& output);
  // Takes back a step the session did not take (it refused the input as non-finite or
  // absurd): the input stays where it was.
  void Retract(const Vector3& step) { input_W_ -= step; }

  const Vector3& input_W() const { return input_W_; }
  ChannelPort& port() { return port_; }
  const ChannelPort& port() const { return port_; }
  const PortEnergy& energy() const { return port_.energy(); }

 private:
  ChannelPort port_;
  bool observes_;
  Vector3 input_W_ = Vector3::Zero();    // the session's last input position
  Vector3 f_env_W_ = Vector3::Zero();    // the session's last force
  int touched_ = -1;                     // and the object it touched
  Vector3 avatar_W_ = Vector3::Zero();   // and its avatar (proxy)
};

}  // namespace hapticd::remote
