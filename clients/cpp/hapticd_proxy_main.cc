// hapticd-proxy: a simulated haptic device (or many) served by hapticd over the real
// UDP channel, or by a plain UDP echo for the latency baseline. See proxy_options.cc for
// the command line; prints one JSON line.
#include <pthread.h>
#include <sys/resource.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <memory>
#include <string_view>
#include <system_error>
#include <thread>
#include <vector>
#include <fmt/format.h>
#include <asio/ip/udp.hpp>

#include "hapticd/version.h"
#include "clients/cpp/control_client.h"
#include "clients/cpp/local_model_device.h"
#include "clients/cpp/proxy_loop.h"
#include "clients/cpp/proxy_options.h"
#include "clients/cpp/sim_device_driver.h"
#include "clients/cpp/tick_schedule.h"
#include "hapticd/v1/hapticd.pb.h"
#include "server/net/proto_convert.h"

namespace {

using namespace hapticd::proxy;

// Where the held devices are: free space above the scene, and 2 mm into the floor.
const Vector3 kStillPoint_W(0, 0, 0.1);
const Vector3 kPressPoint_W(0.05, 0, -0.002);

// One device as the options describe it.
std::unique_ptr<DeviceDriver> MakeDriver(const ProxyOptions& options) {
  DeviceCaps caps;
  caps.kind = options.mode;
  caps.max_force = options.max_force;
  caps.rate_hz = options.rate_hz;
  switch (options.path) {
    case PathKind::kStill:
      caps.start_W = kStillPoint_W;
      return std::make_unique<HeldDeviceDriver>(caps);
    case PathKind::kPress:
      caps.start_W = kPressPoint_W;
      return std::make_unique<HeldDeviceDriver>(caps);
    case PathKind::kStroke:
    case PathKind::kCustom:
      break;
  }
  // the simulated hand starts at rest where its path starts
  std::vector<hapticd::sim::PathPoint> path =
      options.path == PathKind::kStroke ? MakeStrokePath(options.seconds) : options.custom_path;
  const Vector3 start_W = path.front().p_W;
  return std::make_unique<SimDeviceDriver>(caps, MakeDemoHand(std::move(path)), MakeDemoDevice(start_W));
}

// The echo's address: a numeric one, or the first a name resolves to.
asio::ip::udp::endpoint ResolveUdp(const HostPort& target) {
  asio::io_context context;
  asio::ip::udp::resolver resolver(context);
  std::error_code error;
  const auto results = resolver.resolve(target.host, std::to_string(target.port), error);
  if (error || results.empty()) {
    throw std::system_error(error, fmt::format("cannot resolve {}:{}", target.host, target.port));
  }
  return *results.begin();
}

// SIGINT and SIGTERM end the run early (the report is still printed): they are blocked
// in every thread but a watcher that waits for them and sets stop.
class SignalWatcher {
 public:
  explicit SignalWatcher(std::atomic<bool>& stop) {
    sigemptyset(&signals_);
    sigaddset(&signals_, SIGINT);
    sigaddset(&signals_, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
    thread_ = std::thread([this, &stop] {
      const timespec poll{0, 100'000'000};
      while (!done_.load()) {
        if (sigtimedwait(&signals_, nullptr, &poll) > 0) stop.store(true);
      }
    });
  }
  ~SignalWatcher() {
    done_.store(true);
    thread_.join();
  }

 private:
  sigset_t signals_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

double Us(double ns) { return ns / 1000; }

// CPU time this process has used, user and system, s.
double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + t.tv_usec * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// A number as JSON: null when not finite.
std::string OrNull(double value) { return std::isfinite(value) ? fmt::format("{:.7f}", value) : std::string("null"); }
std::string JsonVector(const Vector3& v) { return fmt::format("[{}, {}, {}]", OrNull(v.x()), OrNull(v.y()), OrNull(v.z())); }

void PrintReport(const ProxyOptions& options, int priority, double cpu_s, const ProxyReport& r) {
  fmt::print(
      "{{\"target\": \"{}\", \"peer\": \"{}\", \"sessions\": {}, \"threads\": {}, \"rate_hz\": {}, \"seconds\": {}, "
      "\"realtime_priority\": {}, \"ticks\": {}, "
      "\"rtt_p50_us\": {:.1f}, \"rtt_p90_us\": {:.1f}, \"rtt_p99_us\": {:.1f}, \"rtt_p999_us\": {:.1f}, "
      "\"rtt_max_us\": {:.1f}, \"wire_rtt_p50_us\": {:.1f}, \"wire_rtt_p99_us\": {:.1f}, "
      "\"wire_rtt_p999_us\": {:.1f}, \"wire_rtt_max_us\": {:.1f}, \"lateness_p50_us\": {:.1f}, \"lateness_p99_us\": {:.1f}, "
      "\"lateness_p999_us\": {:.1f}, \"lateness_max_us\": {:.1f}, \"deadline_misses\": {}, \"overruns\": {}, "
      "\"late_states\": {}, \"send_lateness_p50_us\": {:.1f}, \"send_lateness_p99_us\": {:.1f}, "
      "\"send_lateness_max_us\": {:.1f}, "
      "\"skipped_ticks\": {}, \"packets_sent\": {}, \"packets_answered\": {}, \"packets_late\": {}, "
      "\"packets_lost\": {}, \"stale\": {}, \"bad\": {}, \"send_errors\": {}, \"max_force_n\": {:.4f}, "
      "\"energy_j\": {:.6f}, \"lowest_z_m\": {}, \"lowest_avatar_z_m\": {}, \"final_force_n\": {}, "
      "\"final_position_m\": {}, \"remote_mode\": \"{}\", \"models_adopted\": {}, \"model_version\": {}, "
      "\"model_fragments\": {}, \"models_completed\": {}, \"models_rejected\": {}, \"model_blends\": {}, "
      "\"models_moved\": {}, "
      "\"contacts\": {}, \"watchdog_trips\": {}, \"session_ended\": \"{}\", \"cpu_s\": {:.3f}, "
      "\"tdpa\": {}, \"tdpa_activations\": {}, \"device_energy_in_j\": {:.9f}, \"device_energy_out_j\": {:.9f}, "
      "\"server_energy_in_j\": {:.9f}, \"server_energy_out_j\": {:.9f}, \"channel_energy_j\": {:.9f}, "
      "\"device_repaid_j\": {:.9f}, \"device_owed_j\": {:.9f}, \"stall_work_j\": {:.9f}, "
      "\"deadband\": {}, \"keepalive_ms\": {}, \"states_held\": {}, \"keepalives\": {}, "
      "\"commands_received\": {}, \"commands_predicted\": {}, \"commands_held\": {}, "
      "\"server_commands_sent\": {}}}\n",
      fmt::format("{}:{}", options.target.host, options.target.port), options.echo ? "echo" : "hapticd",
      options.sessions, options.threads, options.rate_hz, options.seconds, priority, r.ticks, Us(r.rtt.p50), Us(r.rtt.p90), Us(r.rtt.p99),
      Us(r.rtt.p999), Us(r.rtt.max), Us(r.wire_rtt.p50), Us(r.wire_rtt.p99), Us(r.wire_rtt.p999),
      Us(r.wire_rtt.max), Us(r.lateness.p50), Us(r.lateness.p99), Us(r.lateness.p999), Us(r.lateness.max), r.deadline_misses,
      r.overruns, r.late_states, Us(r.send_lateness.p50), Us(r.send_lateness.p99), Us(r.send_lateness.max),
      r.skipped_ticks, r.packets.sent, r.packets.answered, r.packets.late, r.packets.lost(),
      r.packets.stale, r.packets.bad, r.packets.send_errors, r.max_force_n, r.energy_j,
      OrNull(r.lowest_z_m), OrNull(r.lowest_avatar_z_m), JsonVector(r.final_f_W), JsonVector(r.final_p_W),
      options.local_model ? "local-model" : "direct", r.models.adopted, r.models.version, r.models.fragments,
      r.models.completed, r.models.rejected, r.models.blends, r.models.moved, r.contacts, r.watchdog_trips,
      r.session_ended, cpu_s, options.tdpa, r.tdpa_activations, r.device_energy.in, r.device_energy.out,
      r.server_end.energy_in, r.server_end.energy_out, r.channel_energy_j(), r.device_repaid_j, r.device_owed_j,
      r.stall_work_j, options.deadband.weber,
      options.deadband.keepalive_s * 1000, r.states_held, r.keepalives,
      r.packets.answered + r.packets.late + r.packets.predicted, r.packets.predicted, r.server_end.commands_held,
      r.server_end.commands_sent);
  std::fflush(stdout);
}

// The token in the first line of path; empty when no file is given.
std::string ReadAccessToken(const std::string& path) {
  if (path.empty()) return {};
  std::ifstream file(path);
  std::string token;
  if (!file || !std::getline(file, token)) {
    throw ControlError(fmt::format("--access-token-file {} cannot be read", path));
  }
  return token;
}

int Run(const ProxyOptions& options) {
  std::atomic<bool> stop{false};
  SignalWatcher watcher(stop);

  // the devices, and a session and link for each
  std::vector<std::unique_ptr<DeviceDriver>> drivers;
  std::vector<std::unique_ptr<RealtimeLink>> links;
  std::vector<std::unique_ptr<LocalModelDevice>> locals;  // local-model sessions' (else null)
  std::unique_ptr<ControlClient> client;
  std::vector<uint32_t> session_ids;
  if (options.echo) {
    const asio::ip::udp::endpoint echo = ResolveUdp(options.target);
    for (int i = 0; i < options.sessions; ++i) {
      drivers.push_back(MakeDriver(options));
      links.push_back(std::make_unique<RealtimeLink>(static_cast<uint32_t>(i + 1), hapticd::net::MakeSessionKey(),
                                                     echo, LinkPeer::kEcho));
    }
  } else {
    const auto timeout = std::chrono::milliseconds(std::llround(options.timeout_s * 1000));
    client = std::make_unique<ControlClient>(options.target.host, options.target.port, timeout, options.tls_ca_file);
    client->Hello("hapticd-proxy", ReadAccessToken(options.access_token_file));
    for (int i = 0; i < options.sessions; ++i) {
      drivers.push_back(MakeDriver(options));
      hapticd::v1::OpenSession open = MakeOpenSession(drivers.back()->caps());
      if (options.local_model) open.set_remote_mode(hapticd::v1::REMOTE_MODE_LOCAL_MODEL);
      open.set_tdpa(options.tdpa);
      if (options.deadband.on()) {
        open.set_deadband(options.deadband.weber);
        open.set_deadband_force_floor(options.deadband.force_floor_n);
        open.set_deadband_position_floor(options.deadband.position_floor_m);
        open.set_deadband_velocity_floor(options.deadband.velocity_floor_mps);
        open.set_keepalive_s(options.deadband.keepalive_s);
      }
      const SessionTicket ticket = client->OpenSession(open);
      session_ids.push_back(ticket.session_id);
      if (options.local_model) {
        // the device renders with the settings the server read from the same request
        Vector3 start_W;
        double timeout_s = 0;
        const hapticd::force::SessionSettings settings = hapticd::net::ReadSessionRequest(open, start_W, timeout_s);
        locals.push_back(std::make_unique<LocalModelDevice>(settings, start_W, MonotonicNowNs()));
      } else {
        locals.push_back(nullptr);
      }
      const asio::ip::udp::endpoint udp = options.udp_via.host.empty() ? ticket.udp_endpoint : ResolveUdp(options.udp_via);
      links.push_back(std::make_unique<RealtimeLink>(ticket.session_id, ticket.key, udp));
    }
  }

  ProxyLoopOptions loop_options;
  loop_options.rate_hz = options.rate_hz;
  loop_options.seconds = options.seconds;
  loop_options.budget_ns = std::llround(options.budget_us * 1000);
  loop_options.miss_threshold_ns = std::llround(options.miss_threshold_us * 1000);
  loop_options.hold_s = options.hold_ms / 1000;
  loop_options.ramp_s = options.ramp_ms / 1000;
  // the sessions dealt out to the loops in turn
  std::vector<std::vector<ProxyChannel>> shares(options.threads);
  for (std::size_t i = 0; i < drivers.size(); ++i) shares[i % shares.size()].push_back(
      {drivers[i].get(), links[i].get(), i < locals.size() ? locals[i].get() : nullptr, options.tdpa,
       options.deadband});
  std::vector<std::unique_ptr<ProxyLoop>> loops;
  std::vector<ProxyLoop*> loop_pointers;
  for (std::vector<ProxyChannel>& share : shares) {
    loops.push_back(std::make_unique<ProxyLoop>(loop_options, std::move(share)));
    loop_pointers.push_back(loops.back().get());
  }
  // each loop on a thread of its own: at real-time priority when granted, else normal (0)
  bool realtime = false;
  const double cpu_before_s = ProcessCpuSeconds();
  const ProxyReport report = RunLoops(loop_pointers, options.realtime_priority, &stop, &realtime);
  const double cpu_s = ProcessCpuSeconds() - cpu_before_s;
  const int priority = realtime ? options.realtime_priority : 0;

  for (const uint32_t id : session_ids) client->CloseSession(id);
  PrintReport(options, priority, cpu_s, report);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ProxyOptions options;
  try {
    const std::vector<std::string_view> args(argv + 1, argv + argc);
    options = ParseProxyOptions(args);
  } catch (const OptionsError& e) {
    std::fprintf(stderr, "hapticd-proxy: %s\n", e.what());
    return 2;
  }
  if (options.help) {
    std::fwrite(Usage().data(), 1, Usage().size(), stdout);
    return 0;
  }
  if (options.version) {
    std::printf("hapticd-proxy %.*s\n", static_cast<int>(hapticd::kVersion.size()), hapticd::kVersion.data());
    return 0;
  }
  try {
    return Run(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hapticd-proxy: %s\n", e.what());
    return 1;
  }
}
