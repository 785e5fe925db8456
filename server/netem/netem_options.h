#pragma once
// hapticd-netem's command line, read into plain options. Bad options throw
// OptionsError with a message naming the flag and its value; --help sets `help`.
// Every impairment flag sets both directions; with --up- (device to server) or --down-
// (server to device) before its name it sets that direction only, whatever the order.

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "server/netem/impairment.h"

namespace hapticd::netem {

class OptionsError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Bounds of what the flags accept (documented in the usage text).
inline constexpr double kMaxDelayMs = 60'000;
inline constexpr int kMaxQueueLimit = 1'000'000;
inline constexpr int kMaxFlows = 4096;
inline constexpr std::size_t kMaxTraceEntries = 10'000'000;
inline constexpr int kMaxSpinUs = 1000;

struct Endpoint {
  std::string host;
  int port = 0;
};

struct NetemOptions {
  bool help = false;
  Endpoint listen;   // where devices send
  Endpoint forward;  // the server
  ImpairmentSpec up;    // device -> server
  ImpairmentSpec down;  // server -> device
  uint64_t seed = 1;
  int queue_limit = 10'000;  // datagrams held per direction at once; more are dropped
  int max_flows = 64;        // devices relayed at once
  double flow_idle_s = 60;   // a flow silent this long may be replaced by a new device
  int realtime_priority = 20;  // SCHED_FIFO when granted; 0: normal scheduling
  double duration_s = 0;       // 0: until SIGINT or SIGTERM
  int spin_us = 0;             // wake this early before a release and spin to it (0: no spin)
};

std::string_view Usage();

// args without the program name.
NetemOptions ParseNetemOptions(std::span<const std::string_view> args);

// One one-way delay (ms) a line; blank lines, lines starting with # and a first line
// that is not a number (a header) are skipped; a line's first comma-separated field is
// the delay. Throws OptionsError naming the flag, file and line.
std::vector<double> ReadDelayTrace(std::string_view flag, const std::string& path);

}  // namespace hapticd::netem
