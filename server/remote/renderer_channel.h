#pragma once

// The renderer's side of one impedance session's channel, as hapticd's realtime thread
// and hapticd-sim's renderer both run it: what the session renders on a tick with a
// device state and on one without, the avatar input's step (through TDPA's port) and
// what its port observes, and when a deadband session's command goes down.
//
// Theory of operation, per tick of the session (times in ns on the renderer's clock):
//
//   a state arrived ---------> ReceiveState(now, p, v, device's in)
//                              StepInput(p): the input steps towards it (TDPA: as far
//                              as the port lets it; the rest is the drift); the session
//                              ticks on it (fresh); ObserveTick
//                              deadband: AnswerDue(now, out of band) -> RecordCommand
//   no state, Predicts(now) -> StepInput(Predict(now)): the last state moved on at its
//     (a deadband, within     velocity, a fresh input to the session's watchdog (the
//     keepalive_s + a period   device sends nothing while nothing leaves its band);
//     of the last state)       ObserveTick; a force out of band goes down (flagged as
//                              a prediction) -> RecordCommand
//   no state otherwise ------> the session ticks on its last input (not fresh: its
//                              watchdog counts the silence); no step, nothing observed
//
// So the port observes exactly the steps the session renders. Without a keep-alive
// (keepalive_s infinite: the simulator's channel, where a side sends only what leaves
// its band) every tick after the first state predicts. Everything is held by value: no
// allocation, no lock, no throw (real-time safe).

#include <cstdint>

#include "server/force/render_session.h"
#include "server/remote/channel_ends.h"
#include "server/remote/deadband.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::remote {

class RendererChannel {
 public:
  RendererChannel() = default;
  // tdpa: two-port passivity (the port limits the input's steps); deadband: its Weber
  // fraction (0: off), force floor and keep-alive (infinite: none). local_model: the
  // device renders from a local model, its port a one-port (channel_ends.h): this end
  // neither observes nor limits, whatever tdpa says.
  RendererChannel(bool tdpa, const DeadbandSettings& deadband, bool local_model = false);
  // Between sessions: the input at start_W, energies zero, no state or command yet.
  void Reset(const Vector3& start_W);

  // A fresh state arrived at now_ns: the device at p_W moving at v_W, its end's energy in.
  void ReceiveState(int64_t now_ns, const Vector3& p_W, const Vector3& v_W, double other_in);
  // Whether a tick without a state at now_ns (period_ns: the session's tick) renders a
  // prediction: a deadband session after its first state, within keepalive_s and a
  // period of the last state (always, without a keep-alive).
  bool Predicts(int64_t now_ns, int64_t period_ns) const;
  // The last state's position moved on at its velocity to now_ns.
  Vector3 Predict(int64_t now_ns) const;
  const Vector3& state_v_W() const { return state_v_W_; }

  // The avatar input's step over dt s towards target_W (the newest state's position, or
  // a prediction; r: the avatar's radius): sets input.p_WD to the input, and under TDPA
  // input.v_WD to the step over dt (which the environment's damping meets). A
  // non-finite target goes to the session as it is (which counts and drops it), no step.
  Vector3 StepInput(const scene::SceneSnapshot& scene, const Vector3& target_W, double r, double dt,
                    force::DeviceInput& input);
  // After the session's tick on that input: the port observes what the input pushed into
  // the environment over step. refused: the session refused the input (non-finite,
  // absurd), which moved nothing: the step is taken back.
  void ObserveTick(const force::TickOutput& output, Vector3 step, bool refused);

  // Deadband sessions: whether f_W leaves the band about the last force sent.
  bool ForceOutOfBand(const Vector3& f_W) const;
  // Deadband sessions: whether a state's answer goes down at now_ns: the first, one
  // whose last command is keepalive_s old, or one whose output is out_of_band (the
  // force, or for a local model a fragment due: the caller's judgement).
  bool AnswerDue(int64_t now_ns, bool out_of_band) const;
  // A command went down at now_ns with force f_W.
  void RecordCommand(const Vector3& f_W, int64_t now_ns);

  bool tdpa() const { return end_.port().control(); }
  const DeadbandSettings& deadband() const { return deadband_; }
  RendererEnd& end() { return end_; }
  const RendererEnd& end() const { return end_; }
  // The newest target the input stepped towards, and how far behind it the input is (m).
  const Vector3& target_W() const { return target_W_; }
  double drift_m() const { return (target_W_ - end_.input_W()).norm(); }
  const Vector3& f_sent_W() const { return f_sent_W_; }
  bool command_sent() const { return command_sent_; }

 private:
  RendererEnd end_{false};
  DeadbandSettings deadband_;
  int64_t keepalive_ns_ = 0;  // INT64_MAX: none
  Vector3 target_W_ = Vector3::Zero();
  // the last state: what silent ticks predict on
  bool state_any_ = false;
  Vector3 state_p_W_ = Vector3::Zero();
  Vector3 state_v_W_ = Vector3::Zero();
  int64_t state_ns_ = 0;
  // the last command sent
  bool command_sent_ = false;
  Vector3 f_sent_W_ = Vector3::Zero();
  int64_t command_sent_ns_ = 0;
};

}  // namespace hapticd::remote
