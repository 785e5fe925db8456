#include "clients/cpp/proxy_options.h"

#include <charconv>
#include <cmath>
#include <fmt/format.h>

namespace hapticd::proxy {
namespace {

constexpr std::string_view kUsage = R"(usage: hapticd-proxy (--server HOST:PORT | --echo HOST:PORT) [options]

A haptic device proxy: a 1 kHz loop (absolute-deadline sleeps) that streams a simulated
device's state to hapticd over UDP and renders the commands that come back. Prints one
JSON line: round-trip and deadline-lateness percentiles (us), packet counters, the
largest force, the ticks in contact, and the proxy's own misses (states it sent later
than the miss threshold after their tick's deadline).

  --server HOST:PORT   hapticd's control endpoint
  --echo HOST:PORT     a plain UDP echo instead (the latency baseline): same loop, same
                       datagrams, no rendering
  --seconds N          length of the run, s (default 5)
  --rate-hz R          the loop's rate (default 1000, at most 10000)
  --sessions N         devices served, one session and socket each (default 1)
  --threads T          loops serving them, one thread each, the sessions dealt out in
                       turn (default 1; at most --sessions and 64)
  --mode M             impedance (default) or admittance
  --path P             what the simulated hand does: stroke (default: press into the
                       floor, slide into the box's side, lift; 2 s a cycle), still (held
                       in free space), press (held 2 mm into the floor), or
                       "t,x,y,z;t,x,y,z;..." (a path of its own, s and m)
  --max-force N        the device's force limit, N (default 10)
  --remote-mode M      direct (default: the device renders each command's force) or
                       local-model (the device renders its force itself, from the local
                       models of the scene the commands carry; impedance only)
  --tdpa               two-port time-domain passivity across the channel (impedance):
                       the device limits the force it renders, the server the avatar's
                       step into the scene, so that the channel cannot generate energy
                       whatever the delay, jitter or loss (in direct mode it then renders
                       no contact force: passive, not transparent)
  --deadband W         perceptual deadband, Weber fraction in [0, 1) (default 0: off;
                       impedance): a state goes up only when the server's prediction of
                       it is off by more than the floors plus W, a command comes down
                       only when its force leaves W |F| + the force floor; a keep-alive
                       each way at least every --keepalive-ms
  --deadband-force-floor N     in (0, 10] (default 0.02)
  --deadband-position-floor M  m, in (0, 0.01] (default 0.0001)
  --deadband-velocity-floor V  m/s, in (0, 1] (default 0.002)
  --keepalive-ms K     with --deadband: the longest either side stays silent, in (0, 25]
                       (default 10; at most half the server's 50 ms watchdog)
  --budget-us U        how long a tick waits for its commands (default 500)
  --miss-threshold-us U  a tick waking later than this counts as a deadline miss, a
                       state sent later than this after its deadline as a late state
                       (default 100)
  --hold-ms M          device watchdog: hold the last command this long (default 50),
  --ramp-ms M          then ramp its force to zero over this long (default 100)
  --timeout-s S        control channel calls (default 5)
  --tls-ca FILE        speak TLS to the server, trusting the certificates in this PEM
                       file (the server requires TLS off loopback)
  --access-token-file FILE  its first line is the server's access token (Hello)
  --udp-via HOST:PORT  send the realtime datagrams here instead of the server's realtime
                       endpoint (an impairment relay in front of it: hapticd-netem
                       --forward to the server's UDP port); with --server only
  --realtime-priority N  SCHED_FIFO priority of the loops (default 20, as hapticd's
                       realtime thread; 0: normal scheduling); without CAP_SYS_NICE the
                       loop runs at normal priority and the report says so
  --help               this text
  --version            print "hapticd-proxy VERSION" and exit

Exit status: 0 after a run (its report printed, also when SIGINT or SIGTERM cut it
short); 1 when the server cannot be reached or refuses the session; 2 for bad options.
)";

// The most samples the loop may buffer (ticks x sessions): 24 bytes each.
constexpr double kMaxSamples = 20e6;
constexpr int kMaxThreads = 64;

double ParseNumber(std::string_view option, std::string_view text) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be a number", option, text));
  }
  return value;
}

// A number in [low, high]; the message names the option, the value and the range.
double ParseInRange(std::string_view option, std::string_view text, double low, double high) {
  const double value = ParseNumber(option, text);
  if (value < low || value > high) {
    throw OptionsError(fmt::format("{} is {}; it must be in [{}, {}]", option, text, low, high));
  }
  return value;
}

// A number in (0, high]; the message names the option, the value and the range.
double ParsePositiveAtMost(std::string_view option, std::string_view text, double high) {
  const double value = ParseNumber(option, text);
  if (!(value > 0 && value <= high)) throw OptionsError(fmt::format("{} is {}; it must be in (0, {}]", option, text, high));
  return value;
}

HostPort ParseTarget(std::string_view option, std::string_view text) {
  try {
    return ParseHostPort(text);
  } catch (const std::invalid_argument& e) {
    throw OptionsError(fmt::format("{} {}", option, e.what()));
  }
}

}  // namespace

std::string_view Usage() { return kUsage; }

std::vector<sim::PathPoint> ParsePath(std::string_view text) {
  std::vector<sim::PathPoint> path;
  // points separated by ';', coordinates by ','
  while (!text.empty()) {
    const std::size_t end = text.find(';');
    const std::string_view point = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view() : text.substr(end + 1);
    const std::string name = fmt::format("--path point {} (\"{}\")", path.size(), point);
    double values[4];
    std::string_view rest = point;
    for (int i = 0; i < 4; ++i) {
      const std::size_t comma = rest.find(',');
      if ((i < 3) == (comma == std::string_view::npos)) {
        throw OptionsError(fmt::format("{} is not t,x,y,z", name));
      }
      values[i] = ParseNumber(name, rest.substr(0, comma));
      rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    }
    if (!path.empty() && !(values[0] > path.back().t)) {
      throw OptionsError(fmt::format("{} has t = {}; it must be after the previous point's {}", name, values[0],
                                     path.back().t));
    }
    path.push_back({values[0], Vector3(values[1], values[2], values[3])});
  }
  if (path.empty()) throw OptionsError("--path is empty; it needs at least one t,x,y,z point");
  return path;
}

ProxyOptions ParseProxyOptions(std::span<const std::string_view> args) {
  ProxyOptions options;
  bool have_target = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    // "--name=value" or "--name value"
    std::string_view name = args[i];
    std::string_view value;
    bool inline_value = false;
    if (const std::size_t equals = name.find('='); name.starts_with("--") && equals != std::string_view::npos) {
      value = name.substr(equals + 1);
      name = name.substr(0, equals);
      inline_value = true;
    }
    if (name == "--help" || name == "-h") {
      options.help = true;
      continue;
    }
    if (name == "--version") {
      options.version = true;
      continue;
    }
    if (name == "--tdpa" && !inline_value) {
      options.tdpa = true;
      continue;
    }
    if (!name.starts_with("--")) throw OptionsError(fmt::format("unexpected argument \"{}\"", name));
    if (!inline_value) {
      if (i + 1 >= args.size()) throw OptionsError(fmt::format("{} needs a value", name));
      value = args[++i];
    }

    if (name == "--server" || name == "--echo") {
      if (have_target) throw OptionsError(fmt::format("{} {}: give one of --server and --echo, once", name, value));
      options.target = ParseTarget(name, value);
      options.echo = name == "--echo";
      have_target = true;
    } else if (name == "--seconds") {
      options.seconds = ParseInRange(name, value, 1e-3, 3600);
    } else if (name == "--rate-hz") {
      options.rate_hz = ParseInRange(name, value, 1, 10000);
    } else if (name == "--sessions") {
      const double sessions = ParseInRange(name, value, 1, 1000);
      if (sessions != std::floor(sessions)) throw OptionsError(fmt::format("--sessions is {}; it must be an integer", value));
      options.sessions = static_cast<int>(sessions);
    } else if (name == "--threads") {
      const double threads = ParseInRange(name, value, 1, kMaxThreads);
      if (threads != std::floor(threads)) throw OptionsError(fmt::format("--threads is {}; it must be an integer", value));
      options.threads = static_cast<int>(threads);
    } else if (name == "--mode") {
      if (value == "impedance") {
        options.mode = DeviceKind::kImpedance;
      } else if (value == "admittance") {
        options.mode = DeviceKind::kAdmittance;
      } else {
        throw OptionsError(fmt::format("--mode is \"{}\"; it must be impedance or admittance", value));
      }
    } else if (name == "--path") {
      if (value == "stroke") {
        options.path = PathKind::kStroke;
      } else if (value == "still") {
        options.path = PathKind::kStill;
      } else if (value == "press") {
        options.path = PathKind::kPress;
      } else {
        options.path = PathKind::kCustom;
        options.custom_path = ParsePath(value);
      }
    } else if (name == "--remote-mode") {
      if (value == "direct") {
        options.local_model = false;
      } else if (value == "local-model") {
        options.local_model = true;
      } else {
        throw OptionsError(fmt::format("--remote-mode is \"{}\"; it must be direct or local-model", value));
      }
    } else if (name == "--tdpa") {
      throw OptionsError(fmt::format("--tdpa takes no value (\"{}\")", value));
    } else if (name == "--deadband") {
      options.deadband.weber = ParseNumber(name, value);
      if (!(options.deadband.weber >= 0 && options.deadband.weber < 1)) {
        throw OptionsError(fmt::format("--deadband is {}; a Weber fraction must be in [0, 1) (0: off)", value));
      }
    } else if (name == "--deadband-force-floor") {
      options.deadband.force_floor_n = ParsePositiveAtMost(name, value, remote::kMaxForceFloorN);
    } else if (name == "--deadband-position-floor") {
      options.deadband.position_floor_m = ParsePositiveAtMost(name, value, remote::kMaxPositionFloorM);
    } else if (name == "--deadband-velocity-floor") {
      options.deadband.velocity_floor_mps = ParsePositiveAtMost(name, value, remote::kMaxVelocityFloorMps);
    } else if (name == "--keepalive-ms") {
      options.deadband.keepalive_s = ParsePositiveAtMost(name, value, remote::kMaxKeepaliveS * 1000) / 1000;
    } else if (name == "--max-force") {
      options.max_force = ParseInRange(name, value, 1e-3, 1e4);
    } else if (name == "--budget-us") {
      options.budget_us = ParseInRange(name, value, 0, 1e6);
    } else if (name == "--miss-threshold-us") {
      options.miss_threshold_us = ParseInRange(name, value, 0, 1e6);
    } else if (name == "--hold-ms") {
      options.hold_ms = ParseInRange(name, value, 0, 1e4);
    } else if (name == "--ramp-ms") {
      options.ramp_ms = ParseInRange(name, value, 0, 1e4);
    } else if (name == "--realtime-priority") {
      const double priority = ParseInRange(name, value, 0, 99);
      if (priority != std::floor(priority)) {
        throw OptionsError(fmt::format("--realtime-priority is {}; it must be an integer", value));
      }
      options.realtime_priority = static_cast<int>(priority);
    } else if (name == "--tls-ca") {
      options.tls_ca_file = value;
    } else if (name == "--access-token-file") {
      options.access_token_file = value;
    } else if (name == "--udp-via") {
      options.udp_via = ParseTarget(name, value);
    } else if (name == "--timeout-s") {
      options.timeout_s = ParseInRange(name, value, 1e-3, 3600);
    } else {
      throw OptionsError(fmt::format("unknown option {} (see --help)", name));
    }
  }
  if (options.help || options.version) return options;
  if (!have_target) throw OptionsError("give --server HOST:PORT or --echo HOST:PORT (see --help)");
  if (options.echo && !options.udp_via.host.empty()) {
    throw OptionsError("--udp-via goes with --server (with --echo, name the relay as the echo)");
  }
  if (options.local_model && (options.echo || options.mode != DeviceKind::kImpedance)) {
    throw OptionsError("--remote-mode local-model is for an impedance device served by hapticd (--server)");
  }
  if ((options.tdpa || options.deadband.on()) && (options.echo || options.mode != DeviceKind::kImpedance)) {
    throw OptionsError(fmt::format("{} is for an impedance device served by hapticd (--server)",
                                   options.tdpa ? "--tdpa" : "--deadband"));
  }
  if (options.threads > options.sessions) {
    throw OptionsError(fmt::format("--threads is {}; it must be at most --sessions ({}): a loop serves one "
                                   "session at least",
                                   options.threads, options.sessions));
  }
  // the loop buffers every tick's samples up front
  const double samples = options.seconds * options.rate_hz * options.sessions;
  if (samples > kMaxSamples) {
    throw OptionsError(fmt::format("--seconds {} x --rate-hz {} x --sessions {} is {:.3g} samples; at most {:.3g} "
                                   "are buffered",
                                   options.seconds, options.rate_hz, options.sessions, samples, kMaxSamples));
  }
  return options;
}

}  // namespace hapticd::proxy
