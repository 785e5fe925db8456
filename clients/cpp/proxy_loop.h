#pragma once
// The device proxy's fixed-rate loop: one thread serving one or more devices, each with
// its own session and socket.
//
// Theory of operation, tick k (due at start + k / rate_hz, tick_schedule.h):
//
//   sleep until the deadline (absolute) ---- woke: lateness = woke - deadline
//   for each device: Read(t_k); its end of the channel observes the work the force
//                    held since the last tick did (remote::DeviceEnd); send its state
//                    (held force = what it rendered since its previous state, rtt_us =
//                    its last round trip, the device end's energies) unless its deadband
//                    holds it back (remote::StateDeadband; a keep-alive goes out when
//                    nothing has for the session's keepalive_s); a state sent
//                    later than the threshold after the deadline is the proxy's own
//                    miss (a late state), whatever the server does
//   wait for the commands until woke + budget, at most the next deadline (LinkSet)
//   for each device: the last state's command not come -> the link gives up on it (a
//                    later one counts as late); the newest command that came since the
//                    previous tick, in time or late, goes to the watchdog; Apply the
//                    watchdog's output (that command, or the held / ramping last one).
//                    A local-model device renders its own force instead
//                    (local_model_device.h) and sends its model version and proxy up.
//                    Under TDPA the force, saturated, goes through the device end's
//                    LimitForce, its allowance the newest energy the server reported,
//                    predicted over the last tick's length (longer after a stall: the
//                    force is held across one, and the brake's bound m / dt with it).
//                    The work a force held across a stall did shows at the next sample;
//                    what it let out beyond the server's energy the port owes, and
//                    repays from the energy that comes in next (its brake on the
//                    handle's motion) before any goes up to the server
//   finished: a miss if the tick woke later than the threshold or ran past the next
//             deadline
//
// The simulated time t_k = k / rate_hz follows the schedule, skipped ticks included, so
// the devices' physics and watchdogs age with the wall clock. Every buffer is sized
// before the first tick: a tick allocates nothing.
//
// Many sessions: RunLoops runs several loops, one thread each, each serving its share of
// the devices, so that one loop's sends do not make the last device's state late.
#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <limits>
#include <vector>

#include "clients/cpp/command_watchdog.h"
#include "clients/cpp/device_driver.h"
#include "clients/cpp/latency_stats.h"
#include "clients/cpp/local_model_device.h"
#include "clients/cpp/realtime_link.h"
#include "server/remote/channel_ends.h"
#include "server/remote/deadband.h"

namespace hapticd::proxy {

struct ProxyLoopOptions {
  double rate_hz = 1000;               // > 0
  double seconds = 5;                  // > 0: the run's length; ticks = round(seconds * rate_hz)
  int64_t budget_ns = 500'000;         // how long after it wakes a tick waits for its commands
                                       // (never past the next tick's deadline)
  int64_t miss_threshold_ns = 100'000;  // a tick waking later than this is a deadline miss
  double hold_s = 0.05;                // device watchdog: hold the last command this long,
  double ramp_s = 0.1;                 // then ramp its force to zero over this long
  int max_backlog_ticks = 10;          // behind by more: skip to the present
};

// One device and the link of its session, and for a local-model session the device's
// own renderer (null: the commands' force is rendered); all owned by the caller.
struct ProxyChannel {
  DeviceDriver* driver = nullptr;
  RealtimeLink* link = nullptr;
  LocalModelDevice* local = nullptr;
  // The channel as the session was opened (hapticd.v1.OpenSession): two-port passivity
  // (impedance devices; the device's end runs here) and the deadband of its states.
  bool tdpa = false;
  remote::DeadbandSettings deadband{};
};

// A run's outcome. Percentiles in ns.
struct ProxyReport {
  int64_t ticks = 0;           // ticks run
  int64_t skipped_ticks = 0;   // ticks skipped after stalls
  int64_t deadline_misses = 0;  // ticks that woke late (> threshold) or overran
  int64_t overruns = 0;        // of which: the work ran past the next deadline
  int64_t late_states = 0;     // states sent more than the miss threshold after their deadline
  Percentiles rtt;             // send -> the loop reading the command (in time only)
  Percentiles wire_rtt;        // send -> the kernel's arrival stamp, late commands included
  Percentiles lateness;        // woke - deadline, per tick
  Percentiles send_lateness;   // send - deadline, per state sent
  LinkCounters packets;        // every link's, summed
  int64_t contacts = 0;        // answered commands that report contact (local model: ticks in contact)
  double max_force_n = 0;      // impedance: largest rendered force; admittance: sensed
  // impedance: the net work the rendered force did on the handles, sum of each tick's
  // held force times the handle's displacement over that tick (the scenario format's
  // energy_j; positive: the rendering generated energy)
  double energy_j = 0;
  // the lowest the handles went (m, world z; the default scene's floor is z = 0), and
  // the lowest their avatars (proxies) went: the commands', a local model's own
  double lowest_z_m = std::numeric_limits<double>::infinity();
  double lowest_avatar_z_m = std::numeric_limits<double>::infinity();
  // the first device's at the end of the run: the force rendered and where its handle was
  Vector3 final_f_W = Vector3::Zero();
  Vector3 final_p_W = Vector3::Zero();
  LocalModelCounters models;  // every local-model device's, summed
  // The channel, every impedance session's summed: the device ends' energies, the
  // server's as its commands reported them, and the ticks whose force the device's port
  // cut (TDPA). channel_energy_j() is the net the channel put in (positive: generated).
  remote::PortEnergy device_energy;
  ServerEnd server_end;
  uint64_t tdpa_activations = 0;
  // TDPA: the energy the device ends took back from the handles to repay what they had
  // let out beyond the server's energy (a prediction short, a force held across a
  // stall), and what they still owed at the end (the channel generated at most that and
  // the server's own, J); and the work the held forces did on the handles across the
  // loop's stalls (the intervals that skipped ticks, each one's positive part), which no
  // per-tick prediction covers.
  double device_repaid_j = 0;
  double device_owed_j = 0;
  double stall_work_j = 0;
  // Deadband: the states held back, and the keep-alives among those sent.
  uint64_t states_held = 0;
  uint64_t keepalives = 0;
  double channel_energy_j() const {
    return (device_energy.out - device_energy.in) + (server_end.energy_out - server_end.energy_in);
  }
  uint64_t watchdog_trips = 0;  // device watchdog: holds that ran out
  std::size_t dropped_samples = 0;  // samples beyond the buffers (none when sized right)
  // The server said a session ended (closed or timed out): the run stops at once.
  std::string session_ended;  // "", "closed" or "timed_out"
};

class ProxyLoop {
 public:
  // Allocates everything the run needs: watchdogs, the epoll set and sample buffers for
  // every tick of every channel. channels non-empty, options valid (positive rate and
  // length, budget and threshold >= 0). Throws std::system_error when epoll fails.
  ProxyLoop(const ProxyLoopOptions& options, std::vector<ProxyChannel> channels);

  // Runs round(seconds * rate_hz) ticks' worth of time, or until *stop turns true (checked
  // each tick; may be null), then waits 20 ms more for late commands. Call once.
  ProxyReport Run(const std::atomic<bool>* stop = nullptr);

  // The run's samples (sorted once Run returned), in ns.
  const LatencyStats& rtt_samples() const { return rtt_; }
  const LatencyStats& wire_rtt_samples() const { return wire_rtt_; }
  const LatencyStats& lateness_samples() const { return lateness_; }
  const LatencyStats& send_lateness_samples() const { return send_lateness_; }

 private:
  // The ended flags any link has seen (0: every session lives).
  uint32_t EndedFlags() const;
  // The tick's states: read every device and send; counts the states sent later than
  // the threshold after deadline_ns.
  void SendStates(double t, int64_t deadline_ns, ProxyReport& report);
  // The tick's outputs (dt: its length; held_s: how long its force is likely held, the
  // last tick's length with the ticks skipped, which TDPA's device end predicts over):
  // take the commands that came, apply what the watchdogs (or the local models) say.
  void ApplyCommands(double t, double dt, double held_s, ProxyReport& report);

  ProxyLoopOptions options_;
  std::vector<ProxyChannel> channels_;
  std::vector<RealtimeLink*> links_;
  LinkSet link_set_;
  std::vector<CommandWatchdog> watchdogs_;
  std::vector<Vector3> held_W_;  // per channel: the force applied since its last state
  std::vector<DeviceKind> kinds_;
  std::vector<double> caps_max_force_;  // per channel: the device's force limit, N
  std::vector<DeviceReading> readings_;  // per channel: this tick's (p_W NaN before the first)
  std::vector<double> reading_t_;        // per channel: its time, s (negative before the first)
  std::vector<remote::DeviceEnd> device_ends_;   // per channel
  std::vector<remote::StateDeadband> deadbands_;  // per channel
  std::vector<uint8_t> sent_;  // per channel: a state went out this tick
  std::vector<uint64_t> states_held_;  // per channel: held back by its deadband
  bool after_stall_ = false;  // the last tick skipped ticks: this sample's interval spans a stall
  LatencyStats rtt_;
  LatencyStats wire_rtt_;
  LatencyStats lateness_;
  LatencyStats send_lateness_;
};

// Runs the loops at once, each on a thread of its own readied by PrepareRealtimeThread
// (priority), and merges their reports: counts summed (ticks too), percentiles over every
// loop's samples, the first session end seen. *realtime: whether every thread was granted
// SCHED_FIFO. loops non-empty; each is run once.
ProxyReport RunLoops(std::span<ProxyLoop* const> loops, int priority, const std::atomic<bool>* stop,
                     bool* realtime);

}  // namespace hapticd::proxy
