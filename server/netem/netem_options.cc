#include "server/netem/netem_options.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <vector>

#include <asio/ip/address.hpp>
#include <fmt/format.h>

namespace hapticd::netem {
namespace {

double ReadNumber(std::string_view flag, std::string_view text, double min, double max, std::string_view what) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value) ||
      value < min || value > max) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be {}", flag, text, what));
  }
  return value;
}

template <typename Int>
Int ReadInt(std::string_view flag, std::string_view text, Int min, Int max) {
  Int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < min || value > max) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be a whole number from {} to {}", flag, text, min, max));
  }
  return value;
}

// A probability: a fraction in [0, 1] or a percentage ("5%").
double ReadProbability(std::string_view flag, std::string_view text) {
  const std::string_view what = "a probability from 0 to 1, or a percentage from 0% to 100%";
  if (text.ends_with('%')) return ReadNumber(flag, text.substr(0, text.size() - 1), 0, 100, what) / 100;
  return ReadNumber(flag, text, 0, 1, what);
}

// HOST:PORT, HOST an IPv4 address or a host name (resolved when the relay starts).
Endpoint ReadEndpoint(std::string_view flag, std::string_view text) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be HOST:PORT (an IPv4 address or a host name, and a "
                                   "port)", flag, text));
  }
  Endpoint endpoint{std::string(text.substr(0, colon)), 0};
  std::error_code error;
  const auto address = asio::ip::make_address(endpoint.host, error);
  const bool name = !endpoint.host.empty() && endpoint.host.size() <= 253 &&
                    std::all_of(endpoint.host.begin(), endpoint.host.end(),
                                [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.'; });
  if (error ? !name : !address.is_v4()) {
    throw OptionsError(
        fmt::format("{} is \"{}\"; \"{}\" is neither an IPv4 address nor a host name", flag, text, endpoint.host));
  }
  endpoint.port = ReadInt<int>(flag, text.substr(colon + 1), 0, 65535);
  return endpoint;
}

// --loss-burst p,r[,loss_bad[,loss_good]]
GilbertElliott ReadBurst(std::string_view flag, std::string_view text) {
  std::vector<std::string_view> fields;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    fields.push_back(text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (fields.size() < 2 || fields.size() > 4) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be P,R[,LOSS_BAD[,LOSS_GOOD]] (probabilities)", flag, text));
  }
  GilbertElliott burst;
  burst.p = ReadProbability(flag, fields[0]);
  burst.r = ReadProbability(flag, fields[1]);
  if (fields.size() > 2) burst.loss_bad = ReadProbability(flag, fields[2]);
  if (fields.size() > 3) burst.loss_good = ReadProbability(flag, fields[3]);
  if (burst.r == 0) throw OptionsError(fmt::format("{} is \"{}\"; R must be above 0 (a burst must end)", flag, text));
  return burst;
}

// The impairment flags without their direction prefix, and what each does to a spec.
using Setter = std::function<void(ImpairmentSpec&, std::string_view flag, std::string_view value)>;

struct ImpairmentFlag {
  std::string_view name;
  Setter set;
};

const std::array<ImpairmentFlag, 9>& ImpairmentFlags() {
  static const std::array<ImpairmentFlag, 9> flags = {{
      {"delay-ms", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         s.delay_ms = ReadNumber(f, v, 0, kMaxDelayMs, fmt::format("a delay from 0 to {} ms", kMaxDelayMs));
       }},
      {"jitter-ms", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         s.jitter_ms = ReadNumber(f, v, 0, kMaxDelayMs, fmt::format("a jitter from 0 to {} ms", kMaxDelayMs));
       }},
      {"jitter-distribution", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         if (v == "uniform") {
           s.jitter_distribution = JitterDistribution::kUniform;
         } else if (v == "normal") {
           s.jitter_distribution = JitterDistribution::kNormal;
         } else {
           throw OptionsError(fmt::format("{} is \"{}\"; it must be uniform or normal", f, v));
         }
       }},
      {"loss", [](ImpairmentSpec& s, std::string_view f, std::string_view v) { s.loss = ReadProbability(f, v); }},
      {"loss-burst", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         s.burst = ReadBurst(f, v);
         s.bursty = true;
       }},
      {"reorder", [](ImpairmentSpec& s, std::string_view f, std::string_view v) { s.reorder = ReadProbability(f, v); }},
      {"duplicate",
       [](ImpairmentSpec& s, std::string_view f, std::string_view v) { s.duplicate = ReadProbability(f, v); }},
      {"rate-kbit", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         s.rate_bytes_per_s = 125 * ReadNumber(f, v, 1, 100e6, "a rate from 1 to 100000000 kbit/s");
       }},
      {"delay-trace", [](ImpairmentSpec& s, std::string_view f, std::string_view v) {
         s.delay_trace_ms = ReadDelayTrace(f, std::string(v));
       }},
  }};
  return flags;
}

const ImpairmentFlag* FindImpairmentFlag(std::string_view name) {
  for (const ImpairmentFlag& flag : ImpairmentFlags()) {
    if (flag.name == name) return &flag;
  }
  return nullptr;
}

constexpr std::string_view kOtherValueFlags[] = {"--listen",    "--forward",    "--seed",
                                                 "--queue-limit", "--max-flows", "--flow-idle-s",
                                                 "--realtime-priority", "--duration-s", "--spin-us"};

}  // namespace

std::string_view Usage() {
  return R"(usage: hapticd-netem --listen HOST:PORT --forward HOST:PORT [impairments] [options]

A UDP relay that impairs what it carries, as Linux's netem would (this kernel has none):
devices send to --listen, it forwards to --forward (the server) and relays the replies
back to each device, every device its own flow. Each direction of each flow draws its
own seeded fate per datagram: loss, then delay and jitter (or a delay trace), then
reordering, a rate cap and duplication. Releases are timed against absolute deadlines
(timerfd) at SCHED_FIFO when granted. The first stdout line is JSON naming the
endpoints, e.g. {"listen": "127.0.0.1:9000", "forward": "127.0.0.1:7461"}; at exit (SIGINT,
SIGTERM or --duration-s) one JSON line sums up each direction. Logs go to stderr.

impairments (both directions; --up-NAME: device to server only, --down-NAME: server to
device only, whatever the order):
  --delay-ms D              constant one-way delay, 0 to 60000 ms (default 0)
  --jitter-ms J             jitter, 0 to 60000 ms: uniform in [-J, J], or normal with
                            standard deviation J cut at 4 J; a delay never goes below 0
  --jitter-distribution X   uniform (default) or normal
  --loss P                  independent loss (P from 0 to 1, or a percentage: 5%)
  --loss-burst P,R[,LB[,LG]]  Gilbert-Elliott loss instead: P(good to bad), P(bad to
                            good) a datagram (R above 0), loss in the bad state (default
                            1) and in the good one (default 0); mean burst 1/R datagrams
  --reorder P               share of datagrams sent at once, skipping the delay
  --duplicate P             share of datagrams sent twice
  --rate-kbit N             rate cap, 1 to 100000000 kbit/s: a datagram leaves after the
                            one before it has left at that rate (keeps the order)
  --delay-trace FILE        per-datagram one-way delays (ms), one a line (a CSV's first
                            column; # comments and a header line skipped), cycled; replaces
                            --delay-ms and --jitter-ms; at most 10000000 lines

options:
  --listen HOST:PORT        where devices send (an IPv4 address or a host name; port 0:
                            any free port)
  --forward HOST:PORT       the server's realtime endpoint (IPv4 address or host name,
                            resolved once at start)
  --seed S                  the fates' seed (default 1): the same seed and the same
                            datagrams give the same fates
  --queue-limit N           datagrams held in each direction at once, 1 to 1000000
                            (default 10000), and at most 64 MiB of them; beyond, dropped
                            and counted (overflow)
  --max-flows N             devices relayed at once, 1 to 4096 (default 64); a new device
                            beyond them takes the place of one silent for --flow-idle-s,
                            else its datagrams are dropped and counted (refused)
  --flow-idle-s S           0.001 to 86400 s (default 60)
  --realtime-priority N     SCHED_FIFO priority, 0 to 99 (default 20; 0: normal
                            scheduling; needs CAP_SYS_NICE, else normal)
  --spin-us N               wake N us (0 to 1000, default 0) before each release and
                            spin to it: the timer's wake-up latency (tens of us on a
                            VM) leaves the error, at the cost of up to N us of CPU per
                            release
  --duration-s S            stop after S seconds (default: run until signalled)
  --help                    this text
)";
}

std::vector<double> ReadDelayTrace(std::string_view flag, const std::string& path) {
  std::ifstream in(path);
  if (!in) throw OptionsError(fmt::format("{} is \"{}\"; the file cannot be read", flag, path));
  std::vector<double> delays;
  std::string line;
  int number = 0;
  bool header_allowed = true;
  while (std::getline(in, line)) {
    ++number;
    std::string_view text = line;
    while (!text.empty() && (text.back() == '\r' || text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
    if (text.empty() || text.starts_with('#')) continue;
    const std::string_view field = text.substr(0, text.find(','));
    double value = 0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    const bool number_ok = error == std::errc() && end == field.data() + field.size() && std::isfinite(value);
    if (!number_ok && header_allowed) {
      header_allowed = false;
      continue;
    }
    header_allowed = false;
    if (!number_ok || value < 0 || value > kMaxDelayMs) {
      throw OptionsError(fmt::format("{} is \"{}\"; line {} is \"{}\", not a delay from 0 to {} ms", flag, path, number,
                                     field, kMaxDelayMs));
    }
    if (delays.size() == kMaxTraceEntries) {
      throw OptionsError(fmt::format("{} is \"{}\"; it has more than {} delays", flag, path, kMaxTraceEntries));
    }
    delays.push_back(value);
  }
  if (delays.empty()) throw OptionsError(fmt::format("{} is \"{}\"; it holds no delays", flag, path));
  return delays;
}

NetemOptions ParseNetemOptions(std::span<const std::string_view> args) {
  NetemOptions options;
  bool have_listen = false, have_forward = false;
  // the impairment flags: every direction's first, then the one-direction ones
  std::vector<std::pair<std::string_view, std::string_view>> both, up, down;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view flag = args[i];
    if (flag == "--help" || flag == "-h") {
      options.help = true;
      return options;
    }
    std::string_view name = flag.starts_with("--") ? flag.substr(2) : std::string_view{};
    auto* list = &both;
    if (name.starts_with("up-")) name.remove_prefix(3), list = &up;
    else if (name.starts_with("down-")) name.remove_prefix(5), list = &down;
    const bool impairment = FindImpairmentFlag(name) != nullptr;
    const bool other = std::find(std::begin(kOtherValueFlags), std::end(kOtherValueFlags), flag) != std::end(kOtherValueFlags);
    if (!impairment && !other) {
      throw OptionsError(flag.starts_with("-") ? fmt::format("unknown option \"{}\" (see --help)", flag)
                                               : fmt::format("unexpected argument \"{}\"", flag));
    }
    if (i + 1 >= args.size()) throw OptionsError(fmt::format("{} needs a value", flag));
    const std::string_view value = args[++i];
    if (impairment) {
      list->emplace_back(flag, value);
    } else if (flag == "--listen") {
      options.listen = ReadEndpoint(flag, value);
      have_listen = true;
    } else if (flag == "--forward") {
      options.forward = ReadEndpoint(flag, value);
      have_forward = true;
    } else if (flag == "--seed") {
      options.seed = ReadInt<uint64_t>(flag, value, 0, UINT64_MAX);
    } else if (flag == "--queue-limit") {
      options.queue_limit = ReadInt<int>(flag, value, 1, kMaxQueueLimit);
    } else if (flag == "--max-flows") {
      options.max_flows = ReadInt<int>(flag, value, 1, kMaxFlows);
    } else if (flag == "--flow-idle-s") {
      options.flow_idle_s = ReadNumber(flag, value, 0.001, 86400, "a time from 0.001 to 86400 s");
    } else if (flag == "--realtime-priority") {
      options.realtime_priority = ReadInt<int>(flag, value, 0, 99);
    } else if (flag == "--spin-us") {
      options.spin_us = ReadInt<int>(flag, value, 0, kMaxSpinUs);
    } else {
      options.duration_s = ReadNumber(flag, value, 0.001, 1e7, "a time from 0.001 to 10000000 s");
    }
  }
  const auto apply = [](const auto& flags, ImpairmentSpec& spec, std::string_view prefix) {
    for (const auto& [flag, value] : flags) FindImpairmentFlag(flag.substr(2 + prefix.size()))->set(spec, flag, value);
  };
  apply(both, options.up, "");
  apply(both, options.down, "");
  apply(up, options.up, "up-");
  apply(down, options.down, "down-");
  if (!have_listen) throw OptionsError("--listen HOST:PORT is required (where devices send)");
  if (!have_forward) throw OptionsError("--forward HOST:PORT is required (the server's realtime endpoint)");
  if (options.forward.port == 0) throw OptionsError("--forward's port is 0; it must name the server's port");
  return options;
}

}  // namespace hapticd::netem
