#pragma once

// One device's rendering state and its per-tick pipeline (Salisbury et al. 2004):
//   device input -> sanity checks -> collision detection and force response (penalty,
//   god-object or finger proxy; or the admittance avatar) -> control (passivity,
//   force and rate limits, watchdog) -> command.
// The session is built off the real-time thread (it preallocates everything); Tick runs
// on it and allocates nothing, takes no lock, throws nothing and logs nothing. Bad input
// yields a safe command and a counted event.

#include <cstdint>
#include <memory>

#include "server/force/session_settings.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::force {

using geometry::Vector3;

struct DeviceInput {
  // False when no new device state arrived this tick (loss, late packet): the session
  // reuses the last one and the watchdog counts the silence.
  bool fresh = true;
  Vector3 p_WD = Vector3::Zero();  // device handle position in W, m
  Vector3 v_WD = Vector3::Zero();  // its velocity, m/s
  // The force the device rendered while it moved to p_WD (held since its previous
  // sample), N: what the passivity observer integrates. Impedance mode.
  Vector3 f_held_W = Vector3::Zero();
  // Admittance mode: the force the person applies at the handle, N.
  Vector3 f_sensed_W = Vector3::Zero();
};

struct TickOutput {
  // Impedance: the force for the device to render, N. Admittance: the sensed force the
  // avatar integrated (after sanity checks).
  Vector3 f_W = Vector3::Zero();
  // Admittance: the pose (position) the device must take. Impedance: the device point.
  Vector3 p_command_W = Vector3::Zero();
  // The avatar: the proxy for proxy methods and admittance, the device point for penalty.
  Vector3 avatar_W = Vector3::Zero();
  bool contact = false;
  int touched_object = -1;  // index in the snapshot of the object touched, or -1
};

// Events counted on the real-time path, read by a non-real-time thread.
struct SessionCounters {
  uint64_t ticks = 0;
  uint64_t nonfinite_inputs = 0;   // NaN or infinite position, velocity or force
  uint64_t absurd_inputs = 0;      // finite but beyond what the device can do
  uint64_t force_saturations = 0;  // ticks whose force hit max_force or max_force_rate
  uint64_t passivity_activations = 0;
  uint64_t watchdog_trips = 0;
  uint64_t constraint_overflows = 0;  // a proxy met more than three planes in a tick
};

class RenderSession {
 public:
  // Throws std::invalid_argument with ValidateSessionSettings' message on bad settings.
  explicit RenderSession(const SessionSettings& settings);
  ~RenderSession();
  RenderSession(RenderSession&&) noexcept;
  RenderSession& operator=(RenderSession&&) noexcept;

  // Places the avatar (proxy) at p_W and clears all dynamic state. Off the real-time
  // path or between ticks.
  void Reset(const Vector3& p_W);

  // One tick of dt seconds against scene. Real-time safe.
  TickOutput Tick(const scene::SceneSnapshot& scene, const DeviceInput& input, double dt);

  const SessionSettings& settings() const { return settings_; }
  const SessionCounters& counters() const { return counters_; }
  // Net energy (J) the passivity observer has seen the rendered force put into the
  // device (positive: generated).
  double observed_energy() const;

 private:
  SessionSettings settings_;
  SessionCounters counters_;
  // Method and control state, allocated once by the constructor.
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace hapticd::force
