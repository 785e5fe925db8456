#pragma once

// The deterministic closed-loop simulator behind hapticd-sim: a scenario's hand, device,
// network channel and renderer (one force::RenderSession, the server's code) run in
// simulated time. No wall clock, no sockets; the only randomness is the channel's, drawn
// from channel.seed, so a scenario always gives the same run, bit for bit.
//
// Theory of operation. Tick k covers [t_k, t_k+1), t_k = k / rate_hz, dt = 1 / rate_hz,
// for k = 0 .. ticks-1. Each tick, in this order:
//
//   device                       channel up             renderer
//   sample x_k -> (q_k, v_k,  --- delay, jitter, --->   newest state by t_k (else
//   f_held or f_sensed)          loss                   fresh = false) -> Tick(dt)
//                                                                |
//   hold F_k over the tick    <-- delay, jitter, ---    command (force or pose)
//   (newest command by t_k)       loss
//   integrate to x_k+1; energy += F_k . (x_k+1 - x_k)
//
// - Sample: the sensed position q_k is x_k rounded to the nearest multiple of
//   device.position_resolution (per axis; 0: exact). The sensed velocity is the finite
//   difference (q_k - q_k-1) / dt when position_resolution > 0 (zero at tick 0), and the
//   true velocity when it is 0. f_held is F_k-1, the force the device held while it moved
//   to x_k (zero at tick 0), for the passivity observer.
// - Impedance: F_k is the newest force command received, saturated to device.max_force
//   (zero before the first, and in place of a non-finite one), held constant over the
//   tick (zero-order hold) while hand and handle move as one body (hand_device.h).
// - Admittance: the device is position-controlled and tracks ideally: over tick k it
//   moves the handle from x_k to the newest pose command received (staying put before
//   the first), arriving at t_k+1, so its velocity is the displacement over dt. The
//   robot carries the hand's inertia; the force it senses is the hand's spring-damper
//   force K_h (path - x) + B_h (path' - v) at the sample (hand.mass is not used). The
//   energy counts the force the device applies to the hand, -f_hand,k, over the
//   displacement: positive means the robot pushed the person. With
//   device.response_time_s = tau > 0 the handle instead follows the command as a
//   first-order lag: x_k+1 = p + (x_k - p) exp(-dt / tau).
// - Kinematic objects (the "motion" extension) move at their constant velocity: after
//   each tick their poses are set to the exact pose at t_k+1 with
//   SceneBuilder::MoveKinematic and a new snapshot is built, as a client's edit would.
// - Remote (FORMAT.md's `remote`; server/remote/): the channel's two sides are the code
//   hapticd-proxy (remote::DeviceEnd, StateDeadband) and hapticd's realtime thread
//   (remote::RendererChannel) run. The messages each way carry, besides the state or
//   the command, the sender's channel energy `in` (two_port_passivity.h), and the state
//   carries the device's proxy and the version of the model it renders. The device's
//   port observes F_k-1 . (q_k - q_k-1) at each sample (sensed positions; admittance:
//   -f_sensed over the move), the renderer's port -F . (its avatar input's step) after
//   each tick; channel_energy_j is the two ports' out - in, summed. With local_model the
//   device's port is a one-port on its local rendering (channel_ends.h): it observes
//   F_k-1 . (q_k - q_k-1 - v_surface dt), v_surface the touched surface's velocity
//   (force::TickOutput::v_surface_W), and the renderer's end observes nothing.
//   * The renderer's session renders, each tick, the newest state that arrived (fresh);
//     else, under a deadband, the last state predicted on at its velocity (fresh too:
//     the device sends nothing while nothing leaves its band); else the last state, not
//     fresh (its watchdog counts the silence). Its avatar input steps only on the ticks
//     it renders a state or a prediction, so its port observes only steps it takes.
//   * direct: as above. With tdpa the renderer's input steps towards the target
//     through its port's LimitStep (the environment: its last force before the
//     watchdog's ramp, the nearest surface and that object's stiffness), and the device
//     holds, each tick, the newest command through its port's LimitForce at the
//     velocity extrapolated to the middle of the tick (v_k + (v_k - v_k-1) / 2),
//     saturated (DeviceEnd::LimitSaturated).
//   * local_model: each tick the device first takes the newest model that arrived
//     (remote::LocalRenderer::Accept), renders from it with its sample (no delay), and
//     sends its state up; the renderer runs its own session on the states as they
//     arrive and cuts a model about the device's proxy as the newest
//     state gives it (remote::CutLocalModel) of radius ModelRadius(max_velocity,
//     measured round trip, the interval until the next model, avatar radius) plus the
//     device point's distance from its proxy, the interval being the longest the
//     device has gone without a newer model (loss), at least a tick. The round trip is the
//     largest measured: the ticks from sending a model to the first state that says
//     the device renders it (before any: kInitialRoundTripS). The session opens with a
//     model cut about the start (version 1, as over the control channel before the
//     first tick: not in packets_down).
//   * deadband w > 0, with the default floors and no keep-alive (FORMAT.md: each side
//     sends only what leaves its band; hapticd-proxy and hapticd add a keep-alive over
//     UDP to tell a quiet peer from a lost one): a state goes up only when
//     remote::StateDeadband offers it; a direct command goes down as hapticd sends one:
//     for a state, the first or one whose force leaves the force deadband
//     (w |F_sent| + kForceFloorN); for a prediction, one whose force leaves it (an
//     admittance pose: when it moves past kPositionFloorM); a model only when the
//     device's proxy has left the middle w R of the last model sent or its reach has
//     outgrown (1 - w) R, its radius R being the reach above (with no interval) /
//     (1 - w). Without deadband every tick sends, a model too.
// - Measures at every sample x_k (and the final x_ticks), true positions throughout:
//   max_penetration_m = max(0, depth of the device point in the deepest object);
//   max_avatar_penetration_m the same for a sphere of the avatar's radius at the device
//   point; max_proxy_penetration_m the same for the avatar where the renderer put it
//   (the proxy, the device point for penalty, the commanded pose for admittance).

#include <functional>
#include <memory>

#include "server/force/render_session.h"
#include "server/remote/local_model.h"
#include "server/scene/scene_builder.h"
#include "server/sim/scenario.h"

namespace hapticd::sim {

// One tick, as the trace CSV writes it (FORMAT.md's columns).
struct TraceRow {
  double t = 0;                            // t_k, s
  Vector3 p_device_W = Vector3::Zero();    // true handle position x_k
  Vector3 v_device_W = Vector3::Zero();    // true handle velocity at t_k
  Vector3 avatar_W = Vector3::Zero();      // the renderer's avatar (admittance: the commanded pose)
  Vector3 f_W = Vector3::Zero();           // impedance: F_k held over the tick; admittance: f_hand,k
  bool contact = false;                    // the renderer's avatar touched an object this tick
};

struct SimSummary {
  int64_t ticks = 0;
  double max_force_n = 0;       // max |F_k| (impedance) or max |f_hand,k| (admittance)
  double max_penetration_m = 0;
  double energy_j = 0;          // sum F_k . (x_k+1 - x_k), see the theory of operation
  double max_avatar_penetration_m = 0;
  double max_proxy_penetration_m = 0;
  int64_t contact_ticks = 0;
  Vector3 final_device_W = Vector3::Zero();  // x_ticks
  Vector3 final_avatar_W = Vector3::Zero();  // the avatar after the last tick
  double observed_energy_j = 0;              // what the session's passivity observer saw
  force::SessionCounters counters;           // the session's event counters
  uint64_t packets_lost_up = 0;
  uint64_t packets_lost_down = 0;
  int64_t ticks_without_input = 0;    // the renderer got no new device state
  int64_t ticks_without_command = 0;  // the device got no new command
  int substeps = 0;                   // integrator substeps per tick (impedance)
  // remote (see above)
  uint64_t packets_up = 0;    // messages put on the channel, before loss
  uint64_t packets_down = 0;
  double channel_energy_j = 0;
  double max_drift_m = 0;     // renderer's avatar input behind the newest state (tdpa)
  uint64_t tdpa_device_activations = 0;
  uint64_t tdpa_renderer_activations = 0;
  uint64_t models_taken = 0;       // local_model: models the device switched to
  uint64_t model_blends = 0;       // switches between models that disagreed near the avatar
  int64_t ticks_outside_model = 0; // the device's avatar beyond its model's ball
  double max_model_radius_m = 0;
};

using TraceSink = std::function<void(const TraceRow&)>;

// The round trip a local model's radius assumes before the first is measured, s.
inline constexpr double kInitialRoundTripS = 0.2;

class Simulator {
 public:
  // Builds the scene and the render session. Throws ScenarioError naming the field when
  // the scene builder refuses an object ("scene.objects[1].shape.radius is -1; ...").
  explicit Simulator(Scenario scenario);

  // Runs every tick, calling trace (when set) once per tick in order. Call once.
  SimSummary Run(const TraceSink& trace = {});

 private:
  // Moves the kinematic objects to their poses at time t and builds the next snapshot
  // (versions start at 1 for the scene as given; tick k renders version k + 1).
  void MoveKinematicObjects(double t, uint64_t version);
  // Deepest penetration (>= 0) of a sphere of radius r at c_W into the current scene.
  double CalcPenetration(const Vector3& c_W, double r) const;

  Scenario scenario_;
  scene::SceneBuilder builder_;
  std::shared_ptr<const scene::SceneSnapshot> snapshot_;
  force::RenderSession session_;
  std::vector<int> kinematic_;  // indices into scenario_.objects
  bool ran_ = false;
};

}  // namespace hapticd::sim
