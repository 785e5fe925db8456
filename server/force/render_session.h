#pragma once

// One device's rendering state and its per-tick pipeline (Salisbury et al. 2004):
//   device input -> sanity checks -> collision detection and force response (penalty,
//   god-object or finger proxy; or the admittance avatar) -> control (passivity,
//   force and rate limits, watchdog) -> command.
// The session is built off the real-time thread (it preallocates everything); Tick runs
// on it and allocates nothing, takes no lock, throws nothing and logs nothing. Bad input
// yields a safe command and a counted event.
//
// Each tick's queries run under a work budget (geometry::WorkMeter), so that no spot of
// a scene can make one session's tick delay the others' on the real-time thread. The
// budget is a bucket: a tick may spend all of it, but it refills by a quarter per tick,
// so a session that overruns tick after tick costs the thread a quarter of a budget per
// tick, not a whole one (at 1 kHz a whole one would take most of the thread's time). A
// tick that spends what the bucket holds (an overrun) is thrown away: the avatar stays where it was, the command
// is the last force of a tick that did not overrun (the last safe one) with this tick's
// watchdog scale, and the overrun is counted. Overruns also count as silence for the watchdog, so a device stuck
// where every tick overruns has its held force ramped down like a silent one's.

#include <cstdint>
#include <memory>

#include "server/force/session_settings.h"
#include "server/query/neighbourhood.h"
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
  // Impedance: the touched surface's own velocity at the avatar, m/s (a kinematic
  // object's motion; zero when not touching): a device's port on a local model observes
  // the force's work relative to it (remote/channel_ends.h).
  Vector3 v_surface_W = Vector3::Zero();
  // The tick spent its work budget: the command is the last safe one (see above).
  bool overrun = false;
  // Impedance: f_W before the watchdog's ramp (equal to it while the watchdog is fed):
  // the force the next fresh input renders at once.
  Vector3 f_unscaled_W = Vector3::Zero();
};

// Work units (geometry::WorkMeter) one tick may spend by default, a few hundred
// microseconds here. Its refill, a quarter per tick, is 1.7 times what the heaviest
// benchmark tick spends, tick after tick (at most 1,450: a 5 mm finger proxy sliding on
// a sphere of 1M triangles asking the whole scene, 1,064 gathering its neighbourhood;
// bench/results/render_tick.md).
inline constexpr int64_t kDefaultTickWorkBudget = 10000;

// What a proxy or admittance session gathers around its avatar once a tick and asks its
// queries of (query::Neighbourhood): at most this many objects and mesh triangles. The
// answers are the same whatever it holds; {0, 0}: nothing is gathered and every query
// asks the whole scene (the direct path, kept for comparisons). Penalty sessions ask
// one query a tick and never gather.
struct NeighbourhoodCapacity {
  int objects = query::kDefaultNeighbourObjects;
  int triangles = query::kDefaultNeighbourTriangles;
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
  uint64_t tick_overruns = 0;         // ticks that spent their work budget
};

class RenderSession {
 public:
  // Throws std::invalid_argument with ValidateSessionSettings' message on bad settings,
  // or when work_budget (units per tick, the deployment's) is not positive.
  explicit RenderSession(const SessionSettings& settings, int64_t work_budget = kDefaultTickWorkBudget,
                         const NeighbourhoodCapacity& neighbourhood = {});
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
  // Work units the last tick spent (geometry::WorkMeter; past the budget if it overran).
  int64_t last_tick_work() const { return last_tick_work_; }
  // The last tick's neighbourhood (what it gathered, how often it answered alone).
  const query::Neighbourhood& neighbourhood() const;
  // Net energy (J) the passivity observer has seen the rendered force put into the
  // device (positive: generated).
  double observed_energy() const;

 private:
  // The tick itself, under the meter that Tick starts.
  TickOutput Render(const scene::SceneSnapshot& scene, const DeviceInput& input, double dt);

  SessionSettings settings_;
  int64_t work_budget_;
  int64_t last_tick_work_ = 0;
  int64_t work_credit_;  // what the bucket holds, at most work_budget_
  SessionCounters counters_;
  // Method and control state, allocated once by the constructor.
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace hapticd::force
