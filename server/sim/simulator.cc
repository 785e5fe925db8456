#include "server/sim/simulator.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <stdexcept>

#include "server/query/scene_queries.h"
#include "server/sim/channel.h"
#include "server/sim/sim_device.h"

namespace hapticd::sim {
namespace {

// The channel's two directions draw from separate streams of channel.seed.
constexpr uint32_t kUpStream = 0;
constexpr uint32_t kDownStream = 1;

// A scene builder's message in the scenario's words: "objects[plate].shape..." becomes
// "scene.objects[0].shape...".
std::string RewordSceneError(std::string_view message, int index, std::string_view name) {
  const std::string builder_prefix = fmt::format("objects[{}]", name);
  const std::string prefix = fmt::format("scene.objects[{}]", index);
  if (message.starts_with(builder_prefix)) return prefix + std::string(message.substr(builder_prefix.size()));
  return fmt::format("{} (\"{}\"): {}", prefix, name, message);
}

scene::SceneBuilder BuildScene(const Scenario& scenario) {
  scene::SceneBuilder builder(scenario.scene_settings);
  for (int i = 0; i < static_cast<int>(scenario.objects.size()); ++i) {
    const scene::ObjectSpec& spec = scenario.objects[i];
    try {
      builder.Add(spec);
    } catch (const std::invalid_argument& error) {
      throw ScenarioError(RewordSceneError(error.what(), i, spec.name));
    }
  }
  return builder;
}

force::RenderSession MakeSession(const force::SessionSettings& settings) {
  try {
    return force::RenderSession(settings);
  } catch (const std::invalid_argument& error) {
    throw ScenarioError(error.what());
  }
}

// The pose at time t of an object that moves at constant v_WB and w_WB from X_WB at 0.
scene::Pose PoseAt(const scene::ObjectSpec& spec, double t) {
  scene::Pose pose = spec.X_WB;
  pose.translation += spec.v_WB * t;
  const double angle = spec.w_WB.norm() * t;
  // no spin: the rotation stays as it was
  if (angle > 0) {
    pose.rotation = Eigen::AngleAxisd(angle, spec.w_WB.normalized()).toRotationMatrix() * spec.X_WB.rotation;
  }
  return pose;
}

}  // namespace

Simulator::Simulator(Scenario scenario)
    : scenario_(std::move(scenario)),
      builder_(BuildScene(scenario_)),
      snapshot_(builder_.Build(1)),
      session_(MakeSession(scenario_.session)) {
  for (int i = 0; i < static_cast<int>(scenario_.objects.size()); ++i) {
    if (scenario_.objects[i].motion == scene::Motion::kKinematic) kinematic_.push_back(i);
  }
}

void Simulator::MoveKinematicObjects(double t, uint64_t version) {
  for (int i : kinematic_) {
    const scene::ObjectSpec& spec = scenario_.objects[i];
    builder_.MoveKinematic(spec.name, PoseAt(spec, t), spec.v_WB, spec.w_WB);
  }
  snapshot_ = builder_.Build(version);
}

double Simulator::CalcPenetration(const Vector3& c_W, double r) const {
  const query::SceneContact contact = query::FindDeepestContact(*snapshot_, c_W, r, 0);
  return contact.object >= 0 ? std::max(0.0, contact.depth) : 0.0;
}

SimSummary Simulator::Run(const TraceSink& trace) {
  if (ran_) throw std::logic_error("Simulator::Run called twice");
  ran_ = true;
  const double rate_hz = scenario_.rate_hz;
  const double dt = 1 / rate_hz;
  const double radius = scenario_.session.avatar.radius;
  const bool admittance = scenario_.session.device.mode == force::DeviceMode::kAdmittance;

  SimDevice device(scenario_);
  Channel<DeviceState> up(scenario_.channel, rate_hz, kUpStream, scenario_.ticks);
  Channel<DeviceCommand> down(scenario_.channel, rate_hz, kDownStream, scenario_.ticks);
  session_.Reset(scenario_.device.start_W);
  force::DeviceInput input;  // the renderer's newest device state
  input.p_WD = scenario_.device.start_W;

  SimSummary summary;
  summary.ticks = scenario_.ticks;
  summary.substeps = device.substeps();
  summary.final_avatar_W = scenario_.device.start_W;
  // the device point's penetrations at a sample
  auto measure_device = [&] {
    summary.max_penetration_m = std::max(summary.max_penetration_m, CalcPenetration(device.p_W(), 0));
    summary.max_avatar_penetration_m =
        std::max(summary.max_avatar_penetration_m, CalcPenetration(device.p_W(), radius));
  };

  for (int64_t k = 0; k < scenario_.ticks; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    // device: sample and send up
    up.Send(k, device.Sample(t));

    // renderer: the newest state that has arrived, else the last one, not fresh
    input.fresh = false;
    if (const std::optional<DeviceState> state = up.Receive(k)) {
      input.fresh = true;
      input.p_WD = state->p_W;
      input.v_WD = state->v_W;
      input.f_held_W = state->f_held_W;
      input.f_sensed_W = state->f_sensed_W;
    } else {
      ++summary.ticks_without_input;
    }
    const force::TickOutput output = session_.Tick(*snapshot_, input, dt);
    down.Send(k, DeviceCommand{output.f_W, output.p_command_W});

    // device: the newest command that has arrived
    if (const std::optional<DeviceCommand> command = down.Receive(k)) {
      device.Accept(*command);
    } else {
      ++summary.ticks_without_command;
    }

    // measures and trace at the sample x_k
    const Vector3 avatar_W = admittance ? output.p_command_W : output.avatar_W;
    measure_device();
    summary.max_proxy_penetration_m =
        std::max(summary.max_proxy_penetration_m, CalcPenetration(avatar_W, radius));
    summary.max_force_n = std::max(summary.max_force_n, device.force_W().norm());
    summary.contact_ticks += output.contact ? 1 : 0;
    summary.final_avatar_W = avatar_W;
    if (trace) trace(TraceRow{t, device.p_W(), device.v_W(), avatar_W, device.force_W(), output.contact});

    // the tick's motion, then the scene at t_k+1
    device.Advance(t);
    if (!kinematic_.empty()) {
      MoveKinematicObjects(static_cast<double>(k + 1) / rate_hz, static_cast<uint64_t>(k + 2));
    }
  }
  measure_device();

  summary.energy_j = device.energy_j();
  summary.final_device_W = device.p_W();
  summary.observed_energy_j = session_.observed_energy();
  summary.counters = session_.counters();
  summary.packets_lost_up = up.lost();
  summary.packets_lost_down = down.lost();
  return summary;
}

}  // namespace hapticd::sim
