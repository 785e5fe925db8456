#include "server/sim/simulator.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "server/query/scene_queries.h"
#include "server/sim/channel.h"
#include "server/sim/sim_device.h"
#include "server/remote/deadband.h"
#include "server/remote/channel_ends.h"
#include "server/remote/renderer_channel.h"

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

std::string_view RemoteModeName(RemoteMode mode) {
  return mode == RemoteMode::kDirect ? "direct" : "local_model";
}

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
  const RemoteSpec& remote = scenario_.remote;
  const bool local = remote.mode == RemoteMode::kLocalModel;
  const double weber = remote.deadband;
  const double max_velocity = scenario_.session.device.max_velocity;

  SimDevice device(scenario_);
  Channel<DeviceState> up(scenario_.channel, rate_hz, kUpStream, scenario_.ticks);
  Channel<DeviceCommand> down(scenario_.channel, rate_hz, kDownStream, scenario_.ticks);
  session_.Reset(scenario_.device.start_W);
  force::DeviceInput input;  // the renderer's newest device state
  input.p_WD = scenario_.device.start_W;

  // The channel's two sides as hapticd-proxy (device) and hapticd (renderer) run them:
  // two-port passivity's ends (remote/two_port_passivity.h), the renderer's side of the
  // session (remote/renderer_channel.h) and the device's state deadband, with the
  // deadband's default floors and no keep-alive: FORMAT.md's `remote.deadband` has each
  // side send only what leaves its band (the renderer predicts until the next state).
  remote::DeadbandSettings deadband;
  deadband.weber = weber;
  deadband.keepalive_s = std::numeric_limits<double>::infinity();
  const int64_t period_ns = std::llround(1e9 / rate_hz);
  remote::DeviceEnd device_end(remote.tdpa, scenario_.device.mass, local);
  device_end.Reset(scenario_.device.start_W);
  remote::RendererChannel channel(remote.tdpa, deadband, local);
  channel.Reset(scenario_.device.start_W);
  remote::RendererEnd& renderer_end = channel.end();
  remote::StateDeadband state_deadband(deadband);
  std::optional<remote::LocalRenderer> local_renderer;
  if (local) {
    local_renderer.emplace(scenario_.session);
    local_renderer->Reset(scenario_.device.start_W);
  }

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

  // device end
  DeviceCommand held;                           // the newest command (direct)
  bool has_command = false;
  // renderer end
  Vector3 target_W = scenario_.device.start_W;  // the newest state's position (predicted)
  Vector3 device_avatar_W = scenario_.device.start_W;  // local_model: the device's proxy, as it last said
  Vector3 last_pose_W = scenario_.device.start_W;   // admittance: the last pose commanded
  Vector3 pose_sent_W = Vector3::Zero();            // admittance: the last pose sent (deadband)
  bool pose_sent = false;
  std::shared_ptr<const remote::LocalModel> model;  // the last model cut
  std::vector<int64_t> model_tick = {0};            // tick each version was sent, by version
  uint64_t acked_version = 0;
  double round_trip_s = -1;  // the largest measured; < 0 before the first
  int64_t acked_tick = 0;    // when the newest version was first acked
  double longest_gap_s = 0;  // the longest the device went without a newer model (loss)
  // the model a session opens with, over the control channel before the first tick
  auto model_radius = [&] {
    return remote::ModelRadius(max_velocity, round_trip_s < 0 ? kInitialRoundTripS : round_trip_s,
                               std::max(weber > 0 ? 0.0 : dt, longest_gap_s), radius);
  };
  if (local) {
    model = std::make_shared<const remote::LocalModel>(
        remote::CutLocalModel(*snapshot_, scenario_.device.start_W, model_radius() / (1 - weber), 1, 0));
    model_tick.push_back(0);
    summary.max_model_radius_m = model->radius;
    if (local_renderer->Accept(*model, 0)) ++summary.models_taken;
  }

  // The device's port observes the last tick's work at each sample.
  auto observe_device = [&](const DeviceState& state) {
    device_end.Sample(state.p_W, state.v_W, admittance ? Vector3(-state.f_sensed_W) : state.f_held_W, dt);
  };
  // The device holds a force (impedance) or follows a pose, through its port.
  auto render = [&](const DeviceCommand& command) {
    if (admittance || !remote.tdpa) return device.Accept(command);
    // the port limits what the device can render, as hapticd-proxy's does
    DeviceCommand limited = command;
    limited.f_W = device_end.LimitSaturated(command.f_W, scenario_.session.device.max_force, dt);
    summary.tdpa_device_activations += device_end.port().active() ? 1 : 0;
    device.Accept(limited);
  };

  for (int64_t k = 0; k < scenario_.ticks; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    DeviceState state = device.Sample(t);
    observe_device(state);

    // local_model: the device renders first, from the newest model it has
    force::TickOutput local_output;
    if (local) {
      if (const std::optional<DeviceCommand> command = down.Receive(k)) {
        device_end.ReceiveOtherIn(command->energy_in);
        if (command->model && local_renderer->Accept(*command->model, t)) ++summary.models_taken;
      } else {
        ++summary.ticks_without_command;
      }
      force::DeviceInput own{true, state.p_W, state.v_W, state.f_held_W, state.f_sensed_W};
      local_output = local_renderer->Tick(own, dt);
      if (!local_renderer->Covers(local_output.avatar_W)) ++summary.ticks_outside_model;
      device_end.SetSurfaceVelocity(local_output.v_surface_W);
      render(DeviceCommand{local_output.f_W, local_output.p_command_W, 0, nullptr});
      state.avatar_W = local_output.avatar_W;
      state.model_version = local_renderer->model_version();
    }

    // device: send up (the deadband may hold it back; no keep-alive, as above)
    state.energy_in = device_end.energy().in;
    if (state_deadband.OfferWithKeepalive(t, state.p_W, state.v_W, deadband.keepalive_s, dt) !=
        remote::StateVerdict::kHold) {
      up.Send(k, state);
    }

    // renderer: the newest state that has arrived (fresh); else, under a deadband, the
    // last one predicted on at its velocity (fresh too: the device sends none while
    // nothing leaves its band); else the last one, not fresh (the session's watchdog
    // counts the silence). Its input steps only on ticks it renders a state or a
    // prediction, so its port observes only steps the session takes.
    const int64_t t_ns = k * period_ns;
    input.fresh = false;
    bool stepped = false;
    bool predicted = false;
    if (const std::optional<DeviceState> arrived = up.Receive(k)) {
      input.fresh = stepped = true;
      target_W = arrived->p_W;
      device_avatar_W = arrived->avatar_W;
      input.v_WD = arrived->v_W;
      input.f_held_W = arrived->f_held_W;
      input.f_sensed_W = arrived->f_sensed_W;
      channel.ReceiveState(t_ns, arrived->p_W, arrived->v_W, arrived->energy_in);
      // a model's round trip: from its sending to the first state that renders it
      if (arrived->model_version > acked_version && arrived->model_version < model_tick.size()) {
        acked_version = arrived->model_version;
        round_trip_s = std::max(round_trip_s, static_cast<double>(k - model_tick[acked_version]) * dt);
        if (weber == 0) longest_gap_s = std::max(longest_gap_s, static_cast<double>(k - acked_tick) * dt);
        acked_tick = k;
      }
    } else {
      ++summary.ticks_without_input;
      if (channel.Predicts(t_ns, period_ns)) {
        input.fresh = stepped = predicted = true;
        target_W = channel.Predict(t_ns);
        input.v_WD = channel.state_v_W();
      }
    }
    // the avatar input steps towards the target (through the renderer's port under
    // tdpa); an admittance session's input is the sensed force
    Vector3 step = Vector3::Zero();
    if (stepped && !admittance) {
      step = channel.StepInput(*snapshot_, target_W, radius, dt, input);
      summary.tdpa_renderer_activations += remote.tdpa && renderer_end.port().active() ? 1 : 0;
    } else if (stepped) {
      input.p_WD = target_W;
    }
    if (!admittance) summary.max_drift_m = std::max(summary.max_drift_m, channel.drift_m());
    const force::SessionCounters before = session_.counters();
    const force::TickOutput output = session_.Tick(*snapshot_, input, dt);
    // the renderer's port: what its input pushed into the environment
    if (admittance) {
      renderer_end.port().Observe(output.f_W.dot(output.p_command_W - last_pose_W));
      renderer_end.Remember(output);
      last_pose_W = output.p_command_W;
    } else {
      const force::SessionCounters& after = session_.counters();
      channel.ObserveTick(output, step,
                          after.nonfinite_inputs != before.nonfinite_inputs || after.absurd_inputs != before.absurd_inputs);
    }

    // renderer: send down
    DeviceCommand command{output.f_W, output.p_command_W, renderer_end.energy().in, nullptr};
    if (local) {
      // about the device's proxy (where the features it touches are), out to the device
      // point's reach
      const double reach = model_radius() + (target_W - device_avatar_W).norm();
      const bool cut = weber == 0 || model == nullptr ||
                       (device_avatar_W - model->center_W).norm() > weber * model->radius ||
                       reach > (1 - weber) * model->radius;
      if (cut) {
        model = std::make_shared<const remote::LocalModel>(
            remote::CutLocalModel(*snapshot_, device_avatar_W, reach / (1 - weber), model_tick.size(), t));
        model_tick.push_back(k);
        summary.max_model_radius_m = std::max(summary.max_model_radius_m, model->radius);
        command.model = model;
        down.Send(k, command);
      }
    } else {
      // without a deadband every tick sends; with one, as hapticd answers: a state's
      // answer when it is the first or its force leaves the band, a prediction's when
      // its force does (an admittance pose when it moves past the position floor)
      bool send = weber == 0;
      if (!send && admittance) {
        send = !pose_sent || (command.p_W - pose_sent_W).norm() > remote::kPositionFloorM;
      } else if (!send && stepped) {
        const bool out_of_band = channel.ForceOutOfBand(command.f_W);
        send = predicted ? out_of_band : channel.AnswerDue(t_ns, out_of_band);
      }
      if (send) {
        down.Send(k, command);
        channel.RecordCommand(command.f_W, t_ns);
        pose_sent_W = command.p_W;
        pose_sent = true;
      }
      // device: the newest command that has arrived
      if (const std::optional<DeviceCommand> arrived = down.Receive(k)) {
        device_end.ReceiveOtherIn(arrived->energy_in);
        held = *arrived;
        has_command = true;
        render(held);
      } else {
        ++summary.ticks_without_command;
        if (has_command && remote.tdpa && !admittance) render(held);
      }
    }

    // measures and trace at the sample x_k
    const force::TickOutput& shown = local ? local_output : output;
    const Vector3 avatar_W = admittance ? shown.p_command_W : shown.avatar_W;
    measure_device();
    summary.max_proxy_penetration_m =
        std::max(summary.max_proxy_penetration_m, CalcPenetration(avatar_W, radius));
    summary.max_force_n = std::max(summary.max_force_n, device.force_W().norm());
    summary.contact_ticks += shown.contact ? 1 : 0;
    summary.final_avatar_W = avatar_W;
    if (trace) trace(TraceRow{t, device.p_W(), device.v_W(), avatar_W, device.force_W(), shown.contact});

    // the tick's motion, then the scene at t_k+1
    device.Advance(t);
    if (!kinematic_.empty()) {
      MoveKinematicObjects(static_cast<double>(k + 1) / rate_hz, static_cast<uint64_t>(k + 2));
    }
  }
  measure_device();

  summary.energy_j = device.energy_j();
  summary.final_device_W = device.p_W();
  const force::RenderSession& device_session = local ? local_renderer->session() : session_;
  summary.observed_energy_j = device_session.observed_energy();
  summary.counters = device_session.counters();
  summary.packets_lost_up = up.lost();
  summary.packets_lost_down = down.lost();
  summary.packets_up = up.sent();
  summary.packets_down = down.sent();
  const remote::PortEnergy& d = device_end.energy();
  const remote::PortEnergy& r = renderer_end.energy();
  summary.channel_energy_j = (d.out - d.in) + (r.out - r.in);
  if (local) summary.model_blends = static_cast<uint64_t>(local_renderer->blends());
  return summary;
}

}  // namespace hapticd::sim
