#pragma once
// hapticd's command line, read into plain options. Bad options throw OptionsError with
// a message naming the option and value; --help sets `help`, --version `version`.
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include "server/force/render_session.h"
#include "server/net/control_server.h"
#include "server/net/log.h"
#include "server/scene/scene_limits.h"
#include "server/scene/shape.h"

namespace hapticd::app {

class OptionsError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct ServerOptions {
  bool help = false;
  bool version = false;
  std::string host = "127.0.0.1";
  int tcp_port = 7460;  // 0: any free port
  int udp_port = 7461;
  std::string scene_file;  // empty: the embedded default scene
  scene::RayBackend ray_backend = scene::RayBackend::kNative;  // meshes' default backend
  int max_sessions = 256;
  int realtime_priority = 20;  // SCHED_FIFO priority of the realtime thread; 0: normal
  std::string tls_certificate;  // PEM chain; with tls_key turns TLS on
  std::string tls_key;
  std::string access_token_file;  // first line is the token clients must Hello with
  std::string observer_token_file;  // its first line: a token for read-only connections
  net::LogLevel log_level = net::LogLevel::kInfo;
  // What one scene and one connection may take (--max-objects, --max-connections, ...).
  scene::SceneBudgets scene_budgets;
  int64_t tick_work_budget = force::kDefaultTickWorkBudget;
  int64_t max_request_work = net::kDefaultMaxRequestWork;
  std::size_t max_connections = 64;
  uint32_t max_request_bytes = net::kMaxFrameSize;
  int idle_timeout_s = 600;
};

// The usage text printed by --help.
std::string_view Usage();

// args without the program name. Off loopback, TLS and an access token are required.
ServerOptions ParseServerOptions(std::span<const std::string_view> args);

}  // namespace hapticd::app
