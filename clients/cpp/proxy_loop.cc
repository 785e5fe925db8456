#include "clients/cpp/proxy_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "clients/cpp/tick_schedule.h"
#include "hapticd/v1/hapticd.pb.h"

namespace hapticd::proxy {
namespace {

// After the last tick, how long late commands may still come to be counted as late
// rather than lost.
constexpr int64_t kLateGraceNs = 20'000'000;

std::vector<RealtimeLink*> LinksOf(const std::vector<ProxyChannel>& channels) {
  std::vector<RealtimeLink*> links;
  for (const ProxyChannel& channel : channels) links.push_back(channel.link);
  return links;
}

int64_t TotalTicks(const ProxyLoopOptions& options) { return std::llround(options.seconds * options.rate_hz); }

// The device output a command asks for.
// A reading before the first: no position yet.
DeviceReading NoReading() {
  DeviceReading reading;
  reading.p_W = Vector3::Constant(std::numeric_limits<double>::quiet_NaN());
  return reading;
}

DeviceOutput OutputOf(const net::DeviceCommandSample& command) {
  DeviceOutput output;
  output.f_W = command.f_W;
  output.tau_W = command.tau_W;
  output.p_W = command.p_command_W;
  output.q_W = command.q_command_W;
  return output;
}

}  // namespace

ProxyLoop::ProxyLoop(const ProxyLoopOptions& options, std::vector<ProxyChannel> channels)
    : options_(options),
      channels_(std::move(channels)),
      links_(LinksOf(channels_)),
      link_set_(links_),
      held_W_(channels_.size(), Vector3::Zero()),
      readings_(channels_.size(), NoReading()),
      reading_t_(channels_.size(), -1.0),
      sent_(channels_.size(), 0),
      states_held_(channels_.size(), 0),
      rtt_(static_cast<std::size_t>(TotalTicks(options)) * channels_.size()),
      wire_rtt_(static_cast<std::size_t>(TotalTicks(options)) * channels_.size()),
      lateness_(static_cast<std::size_t>(TotalTicks(options))),
      send_lateness_(static_cast<std::size_t>(TotalTicks(options)) * channels_.size()) {
  // every command's wire round trip, late ones included, goes to one buffer
  for (RealtimeLink* link : links_) link->set_wire_rtt_sink(&wire_rtt_);
  for (const ProxyChannel& channel : channels_) {
    if (channel.local != nullptr) channel.link->set_fragment_sink(channel.local);
  }
  // before any command: no force, and an admittance handle stays where it starts
  for (const ProxyChannel& channel : channels_) {
    const DeviceCaps caps = channel.driver->caps();
    DeviceOutput initial;
    initial.p_W = caps.start_W;
    watchdogs_.emplace_back(initial, options_.hold_s, options_.ramp_s);
    kinds_.push_back(caps.kind);
    caps_max_force_.push_back(caps.max_force);
    device_ends_.emplace_back(channel.tdpa, caps.handle_mass, channel.local != nullptr);
    device_ends_.back().Reset(caps.start_W);
    deadbands_.emplace_back(channel.deadband);
  }
}

void ProxyLoop::SendStates(double t, int64_t deadline_ns, ProxyReport& report) {
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    const DeviceReading reading = channels_[i].driver->Read(t);
    // the work the force held over the last tick did on the handle (readings_ still
    // holds the last tick's)
    if (kinds_[i] == DeviceKind::kImpedance && readings_[i].p_W.allFinite()) {
      const double work = held_W_[i].dot(reading.p_W - readings_[i].p_W);
      report.energy_j += work;
      if (after_stall_) report.stall_work_j += std::max(work, 0.0);
    }
    report.lowest_z_m = std::min(report.lowest_z_m, reading.p_W.z());
    readings_[i] = reading;
    sent_[i] = 0;
    const bool impedance = kinds_[i] == DeviceKind::kImpedance;
    if (impedance) {
      device_ends_[i].Sample(reading.p_W, reading.v_W, held_W_[i], reading_t_[i] < 0 ? 0.0 : t - reading_t_[i]);
    }
    reading_t_[i] = t;
    net::DeviceStateSample state;
    state.p_WD = reading.p_W;
    state.q_WD = reading.q_W;
    state.v_WD = reading.v_W;
    state.w_WD = reading.w_W;
    state.buttons = reading.buttons;
    state.f_sensed_W = reading.f_sensed_W;
    // impedance: what the device rendered since its previous state
    if (kinds_[i] == DeviceKind::kImpedance) state.f_held_W = held_W_[i];
    if (const LocalModelDevice* local = channels_[i].local) {
      state.model_version = local->model_version();
      state.avatar_W = local->avatar_W();
    }
    const int64_t rtt_us = links_[i]->rtt_ns() / 1000;
    state.rtt_us = static_cast<uint32_t>(std::clamp<int64_t>(rtt_us, 0, std::numeric_limits<uint32_t>::max()));
    if (impedance) {
      state.energy_in = device_ends_[i].energy().in;
      state.energy_out = device_ends_[i].energy().out;
    }
    // the deadband: only what the server could not predict, and a keep-alive
    const remote::DeadbandSettings& deadband = channels_[i].deadband;
    if (impedance && deadband.on()) {
      const remote::StateVerdict verdict =
          deadbands_[i].OfferWithKeepalive(t, reading.p_W, reading.v_W, deadband.keepalive_s, 1 / options_.rate_hz);
      if (verdict == remote::StateVerdict::kHold) {
        ++states_held_[i];
        ++report.states_held;
        continue;
      }
      state.keepalive = verdict == remote::StateVerdict::kKeepalive;
      report.keepalives += state.keepalive ? 1 : 0;
      state.states_held = states_held_[i];
    }
    if (!links_[i]->Send(state)) continue;
    sent_[i] = 1;
    // how late the proxy itself sent it
    const int64_t late_ns = std::max<int64_t>(0, links_[i]->send_ns() - deadline_ns);
    send_lateness_.Record(late_ns);
    report.late_states += late_ns > options_.miss_threshold_ns ? 1 : 0;
  }
}

void ProxyLoop::ApplyCommands(double t, double dt, double held_s, ProxyReport& report) {
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    RealtimeLink& link = *links_[i];
    // the last state's answer in time is measured; without one, stop waiting for it
    // (a tick whose state the deadband held back has none to wait for)
    if (!sent_[i]) {
      link.Expire();
    } else if (link.answered()) {
      rtt_.Record(link.rtt_ns());
      report.contacts += link.command().contact && channels_[i].local == nullptr ? 1 : 0;
    } else {
      link.Expire();
    }
    // the newest command goes to the watchdog, in time or late: across a delay longer
    // than a tick, every command is late
    if (link.fresh()) {
      watchdogs_[i].Accept(OutputOf(link.newest()), t);
      link.ClearFresh();
    }
    DeviceOutput output = watchdogs_[i].Output(t);
    Vector3 avatar_W = link.newest().avatar_W;
    if (LocalModelDevice* local = channels_[i].local) {
      const force::TickOutput rendered = local->Tick(readings_[i], held_W_[i], dt);
      output.f_W = rendered.f_W;
      output.tau_W.setZero();
      avatar_W = rendered.avatar_W;
      report.contacts += rendered.contact ? 1 : 0;
      device_ends_[i].SetSurfaceVelocity(rendered.v_surface_W);
    }
    // two-port passivity: what the device lets out is bounded by what the server let in
    if (kinds_[i] == DeviceKind::kImpedance) {
      remote::DeviceEnd& end = device_ends_[i];
      end.ReceiveOtherIn(link.server_end().energy_in);
      if (channels_[i].tdpa) {
        // saturated before (what the port predicts with) and after (its brake may add
        // to it): the force held is the force rendered, as the observer counts it
        output.f_W = end.LimitSaturated(output.f_W, caps_max_force_[i], held_s);
        report.tdpa_activations += end.port().active() ? 1 : 0;
      }
    }
    channels_[i].driver->Apply(output);
    held_W_[i] = output.f_W;
    if (link.newest().sequence != 0 || channels_[i].local != nullptr) {
      report.lowest_avatar_z_m = std::min(report.lowest_avatar_z_m, avatar_W.z());
    }
    const double force = kinds_[i] == DeviceKind::kImpedance ? output.f_W.norm() : readings_[i].f_sensed_W.norm();
    report.max_force_n = std::max(report.max_force_n, force);
  }
  report.final_f_W = held_W_.front();
  report.final_p_W = readings_.front().p_W;
}

uint32_t ProxyLoop::EndedFlags() const {
  uint32_t flags = 0;
  for (const RealtimeLink* link : links_) flags |= link->ended_flags();
  return flags;
}

ProxyReport ProxyLoop::Run(const std::atomic<bool>* stop) {
  const int64_t period_ns = std::llround(1e9 / options_.rate_hz);
  const int64_t total_ticks = TotalTicks(options_);
  // the first deadline one period from now: setup is done, the schedule starts clean
  const TickSchedule schedule(MonotonicNowNs() + period_ns, period_ns, options_.max_backlog_ticks);
  ProxyReport report;
  int64_t tick = 0;
  // how long the force a tick applies is likely held: the last tick's length, skipped
  // ticks included (after a stall, more are likely), never less than a period
  double held_s = 1.0 / options_.rate_hz;
  while (tick < total_ticks && (stop == nullptr || !stop->load(std::memory_order_relaxed))) {
    const int64_t deadline_ns = schedule.DeadlineOf(tick);
    SleepUntilNs(deadline_ns);
    const int64_t woke_ns = MonotonicNowNs();
    const double t = static_cast<double>(tick) / options_.rate_hz;

    // send, wait out the budget from the wake (never past the next deadline), apply
    SendStates(t, deadline_ns, report);
    link_set_.AwaitAll(std::min(woke_ns + options_.budget_ns, schedule.DeadlineOf(tick + 1)));
    ApplyCommands(t, 1.0 / options_.rate_hz, held_s, report);

    // judge the tick, then move on (skipping ahead after a stall)
    const int64_t finished_ns = MonotonicNowNs();
    const TickTiming timing = schedule.Classify(tick, woke_ns, finished_ns, options_.miss_threshold_ns);
    lateness_.Record(timing.lateness_ns);
    ++report.ticks;
    report.deadline_misses += timing.missed() ? 1 : 0;
    report.overruns += timing.overran ? 1 : 0;
    const int64_t next = schedule.NextTick(tick, finished_ns);
    report.skipped_ticks += next - tick - 1;
    after_stall_ = next - tick > 1;
    held_s = static_cast<double>(next - tick) / options_.rate_hz;
    tick = next;
    // an ended session renders nothing more: stop rather than stream into silence
    if (const uint32_t ended = EndedFlags(); ended != 0) {
      report.session_ended = (ended & v1::COMMAND_FLAGS_SESSION_CLOSED) ? "closed" : "timed_out";
      break;
    }
  }

  // commands still on their way count as late, not lost
  SleepUntilNs(MonotonicNowNs() + kLateGraceNs);
  for (std::size_t i = 0; i < links_.size(); ++i) {
    links_[i]->Drain();
    report.packets += links_[i]->counters();
    report.watchdog_trips += watchdogs_[i].trips();
    if (kinds_[i] == DeviceKind::kImpedance) {
      report.device_energy.in += device_ends_[i].energy().in;
      report.device_energy.out += device_ends_[i].energy().out;
      report.device_repaid_j += device_ends_[i].port().repaid();
      report.device_owed_j += device_ends_[i].port().owed();
      report.server_end += links_[i]->server_end();
    }
    if (channels_[i].local != nullptr) report.models += channels_[i].local->counters();
  }
  report.rtt = rtt_.Summarize();
  report.wire_rtt = wire_rtt_.Summarize();
  report.lateness = lateness_.Summarize();
  report.send_lateness = send_lateness_.Summarize();
  report.dropped_samples = rtt_.dropped() + wire_rtt_.dropped() + lateness_.dropped() + send_lateness_.dropped();
  return report;
}

namespace {

// The percentiles of every loop's samples of one kind together.
Percentiles MergedPercentiles(std::span<ProxyLoop* const> loops, const LatencyStats& (ProxyLoop::*samples)() const) {
  std::size_t count = 0;
  for (const ProxyLoop* loop : loops) count += (loop->*samples)().count();
  LatencyStats merged(count);
  for (const ProxyLoop* loop : loops) {
    for (const int64_t value : (loop->*samples)().samples()) merged.Record(value);
  }
  return merged.Summarize();
}

}  // namespace

ProxyReport RunLoops(std::span<ProxyLoop* const> loops, int priority, const std::atomic<bool>* stop,
                     bool* realtime) {
  // every loop on a thread of its own, readied as a fixed-rate thread
  std::vector<ProxyReport> reports(loops.size());
  std::vector<uint8_t> granted(loops.size(), 0);
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < loops.size(); ++i) {
    threads.emplace_back([&, i] {
      granted[i] = PrepareRealtimeThread(priority) ? 1 : 0;
      reports[i] = loops[i]->Run(stop);
    });
  }
  for (std::thread& thread : threads) thread.join();
  if (realtime != nullptr) *realtime = std::all_of(granted.begin(), granted.end(), [](uint8_t g) { return g != 0; });

  // counts add up; percentiles come from all the samples; the first device is the first loop's
  ProxyReport merged;
  merged.final_f_W = reports.front().final_f_W;
  merged.final_p_W = reports.front().final_p_W;
  for (const ProxyReport& r : reports) {
    merged.ticks += r.ticks;
    merged.skipped_ticks += r.skipped_ticks;
    merged.deadline_misses += r.deadline_misses;
    merged.overruns += r.overruns;
    merged.late_states += r.late_states;
    merged.packets += r.packets;
    merged.contacts += r.contacts;
    merged.max_force_n = std::max(merged.max_force_n, r.max_force_n);
    merged.energy_j += r.energy_j;
    merged.lowest_z_m = std::min(merged.lowest_z_m, r.lowest_z_m);
    merged.lowest_avatar_z_m = std::min(merged.lowest_avatar_z_m, r.lowest_avatar_z_m);
    merged.models += r.models;
    merged.watchdog_trips += r.watchdog_trips;
    merged.device_energy.in += r.device_energy.in;
    merged.device_energy.out += r.device_energy.out;
    merged.server_end += r.server_end;
    merged.tdpa_activations += r.tdpa_activations;
    merged.device_repaid_j += r.device_repaid_j;
    merged.device_owed_j += r.device_owed_j;
    merged.stall_work_j += r.stall_work_j;
    merged.states_held += r.states_held;
    merged.keepalives += r.keepalives;
    merged.dropped_samples += r.dropped_samples;
    if (merged.session_ended.empty()) merged.session_ended = r.session_ended;
  }
  merged.rtt = MergedPercentiles(loops, &ProxyLoop::rtt_samples);
  merged.wire_rtt = MergedPercentiles(loops, &ProxyLoop::wire_rtt_samples);
  merged.lateness = MergedPercentiles(loops, &ProxyLoop::lateness_samples);
  merged.send_lateness = MergedPercentiles(loops, &ProxyLoop::send_lateness_samples);
  return merged;
}

}  // namespace hapticd::proxy
