#pragma once
// hapticd-proxy's command line, read into plain options. Bad options throw OptionsError
// with a message naming the option and its value; --help sets `help`, --version
// `version`.
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "clients/cpp/control_client.h"
#include "clients/cpp/device_driver.h"
#include "server/remote/deadband.h"
#include "server/sim/scenario.h"

namespace hapticd::proxy {

class OptionsError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// What the simulated hand does (--path).
enum class PathKind {
  kStroke,  // the demo's stroke: press into the floor, slide into the box, lift (simulated)
  kStill,   // held still in free space at (0, 0, 0.1)
  kPress,   // held still 2 mm into the floor at (0.05, 0, -0.002): in contact every tick
  kCustom,  // the given [t, x, y, z] points (simulated)
};

struct ProxyOptions {
  bool help = false;
  bool version = false;
  bool echo = false;  // against a plain UDP echo (--echo) instead of hapticd (--server)
  HostPort target;    // the server's control endpoint, or the echo's UDP endpoint
  double seconds = 5;
  double rate_hz = 1000;
  int sessions = 1;
  int threads = 1;  // loops (threads) serving the sessions, in [1, sessions]
  DeviceKind mode = DeviceKind::kImpedance;
  PathKind path = PathKind::kStroke;
  std::vector<sim::PathPoint> custom_path;  // kCustom only
  double max_force = 10;          // N
  bool local_model = false;       // --remote-mode local-model
  bool tdpa = false;              // --tdpa: two-port passivity across the channel
  remote::DeadbandSettings deadband;  // --deadband W and its floors, --keepalive-ms
  double budget_us = 500;         // a tick's wait for its commands
  double miss_threshold_us = 100;  // a tick waking later than this is a miss
  double hold_ms = 50;            // device watchdog
  double ramp_ms = 100;
  double timeout_s = 5;  // control channel calls
  std::string tls_ca_file;        // non-empty: TLS to the server, trusting this PEM file
  std::string access_token_file;  // its first line is the server's access token
  HostPort udp_via;  // host non-empty: realtime datagrams go here (a relay), not to the server
  int realtime_priority = 20;  // SCHED_FIFO priority of the loop's thread; 0: normal
};

// The usage text printed by --help.
std::string_view Usage();

// args without the program name; options as "--name value" or "--name=value".
ProxyOptions ParseProxyOptions(std::span<const std::string_view> args);

// "t,x,y,z;t,x,y,z;...": at least one point, times strictly increasing. Throws
// OptionsError naming the bad point.
std::vector<sim::PathPoint> ParsePath(std::string_view text);

}  // namespace hapticd::proxy
