#pragma once

// A haptic scenario (../shared/scenarios/FORMAT.md) once read and validated: plain values
// in SI units, ready for the simulator. scenario_parser.h reads it from JSON.

#include <cstdint>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "server/force/session_settings.h"
#include "server/scene/scene_builder.h"

namespace hapticd::sim {

using geometry::Vector3;

// A scenario that cannot be run: bad JSON, an unknown field, a wrong type or an
// impossible value. The message names the field by its path from the scenario's root
// ("device.mass is -1; it must be > 0", "scene.objects[0].shape.radius ...").
class ScenarioError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// One point of the hand's path: where the hand wants to be at time t (s).
struct PathPoint {
  double t = 0;
  Vector3 p_W = Vector3::Zero();
};

// The person: a mass-spring-damper pulled towards a piecewise-linear path.
struct HandSpec {
  double mass = 0;       // kg, >= 0
  double stiffness = 0;  // N/m, >= 0
  double damping = 0;    // N·s/m, >= 0
  std::vector<PathPoint> path;  // at least one point, times strictly increasing
};

// The device's mechanics (its mode and force limit are in SessionSettings::device).
struct DeviceSpec {
  double mass = 0;                 // kg, > 0: the handle and what moves with it
  double damping = 0;              // N·s/m, >= 0: the mechanism's own viscous friction
  double position_resolution = 0;  // m, >= 0: the sensed position's quantum (0: exact)
  Vector3 start_W = Vector3::Zero();  // where the handle starts, at rest
  // s, >= 0, admittance only: the robot follows its pose command as a first-order lag
  // with this time constant (0: it arrives by the end of the tick).
  double response_time_s = 0;
};

// The network between device and renderer, the same in both directions.
struct ChannelSpec {
  double delay_s = 0;   // >= 0
  double jitter_s = 0;  // >= 0: an extra delay drawn uniformly from [0, jitter_s]
  double loss = 0;      // in [0, 1]: the probability that a message is lost
  uint64_t seed = 1;
};

// How the device and the renderer share the work across the channel (FORMAT.md's
// `remote`; left out: direct, no passivity, no deadband).
enum class RemoteMode { kDirect, kLocalModel };
struct RemoteSpec {
  RemoteMode mode = RemoteMode::kDirect;
  bool tdpa = false;    // two-port time-domain passivity (remote/two_port_passivity.h)
  double deadband = 0;  // Weber fraction in [0, 1), 0: every tick sends
};

// "direct", "local_model".
std::string_view RemoteModeName(RemoteMode mode);

struct Scenario {
  double rate_hz = 1000;   // > 0: the loop's rate
  double duration_s = 0;   // > 0
  int64_t ticks = 0;       // round(duration_s * rate_hz), >= 1
  scene::SceneSettings scene_settings;
  std::vector<scene::ObjectSpec> objects;  // kinematic ones move at their v_WB, w_WB
  force::SessionSettings session;          // avatar, device mode and limits, control
  DeviceSpec device;
  HandSpec hand;
  ChannelSpec channel;
  RemoteSpec remote;
};

}  // namespace hapticd::sim
