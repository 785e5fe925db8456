#include "server/app/server_options.h"

#include <algorithm>
#include <charconv>

#include <asio/ip/address.hpp>
#include <fmt/format.h>

#include "server/net/session_table.h"

namespace hapticd::app {
namespace {

template <typename Int = int>
Int ReadInt(std::string_view option, std::string_view text, Int min, Int max) {
  Int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < min || value > max) {
    throw OptionsError(fmt::format("{} is \"{}\"; it must be a whole number from {} to {}", option, text, min, max));
  }
  return value;
}

std::size_t ReadCount(std::string_view option, std::string_view text, std::size_t max) {
  return ReadInt<std::size_t>(option, text, 1, max);
}

// Every option that takes a value; anything else starting with -- is unknown.
constexpr std::string_view kValueOptions[] = {
    "--host", "--tcp-port", "--udp-port", "--scene", "--ray-backend", "--max-sessions",
    "--realtime-priority", "--tls-cert", "--tls-key", "--access-token-file", "--observer-token-file", "--log-level",
    "--max-objects", "--max-mesh-triangles", "--max-scene-triangles", "--max-connections",
    "--max-request-bytes", "--idle-timeout", "--tick-work-budget", "--max-request-work"};

}  // namespace

std::string_view Usage() {
  return R"(usage: hapticd [options]

Networked haptic rendering server: a UDP realtime channel for devices at 1 kHz and a
TCP control channel (length-prefixed protobuf, proto/hapticd/v1/hapticd.proto) for
scene edits, queries, sessions and telemetry. The first line on stdout is JSON naming
the bound endpoints, e.g. {"tcp": "127.0.0.1:7460", "udp": "127.0.0.1:7461"}; logs go
to stderr. SIGINT or SIGTERM stop it.

options:
  --host ADDRESS            address to bind (default 127.0.0.1); anything but loopback
                            needs --tls-cert, --tls-key and --access-token-file
  --tcp-port PORT           control channel port (default 7460; 0: any free port)
  --udp-port PORT           realtime channel port (default 7461; 0: any free port)
  --scene FILE              start on this scene file ({"scene": {...}} in the scenario
                            format of shared/scenarios/FORMAT.md) instead of the
                            embedded default scene
  --ray-backend B           native or embree: what answers the meshes' segment and
                            closest-point queries unless an object names its own
                            (the same answers; default native)
  --max-sessions N          device sessions held at once (default 256)
  --realtime-priority N     SCHED_FIFO priority of the realtime thread (default 20;
                            0: normal scheduling; needs CAP_SYS_NICE, else normal)
  --tls-cert FILE           PEM certificate chain: TLS on the control channel
  --tls-key FILE            PEM private key for --tls-cert
  --access-token-file FILE  its first line is the token clients send in Hello (the
                            operator's: every request); with a token, every
                            connection, loopback too, must Hello with one first
  --observer-token-file FILE  its first line is a second token, for connections that
                            may only read (scene, queries, telemetry, stats); needs
                            --access-token-file
  --log-level LEVEL         debug, info, warning or error (default info)
  --help                    this text
  --version                 print "hapticd VERSION" and exit

budgets (what one client can make the server hold or do; over one, a clear error):
  --max-objects N           objects in the scene (default 1024)
  --max-mesh-triangles N    triangles in one mesh (default 2000000)
  --max-scene-triangles N   triangles in all the scene's meshes (default 4000000)
  --max-connections N       control connections at once (default 64)
  --max-request-bytes N     bytes in one control frame, request or reply (default
                            67108864; before a successful Hello 4096)
  --idle-timeout S          seconds a control connection without subscriptions may
                            send nothing before it is closed (default 600)
  --tick-work-budget N      work units (BVH nodes, primitives, objects, eight hull
                            vertices or faces) one session's render tick may
                            spend, from 100 to 10000000 (default 10000),
                            refilled by a quarter a tick; a tick over it sends
                            the last safe force, flagged OVERRUN, so no spot of
                            the scene delays other sessions
  --max-request-work N      work units (as above) one query request (ray casts,
                            closest points, contacts; one or a batch) may spend
                            on the control thread, from 10000 to 1000000000000
                            (default 100000000, about 3 s here); a request over
                            it is refused (RESOURCE_EXHAUSTED), so that no query
                            holds up the other clients for long: ask in smaller
                            batches
)";
}

ServerOptions ParseServerOptions(std::span<const std::string_view> args) {
  ServerOptions options;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view option = args[i];
    if (option == "--help" || option == "-h") {
      options.help = true;
      return options;
    }
    if (option == "--version") {
      options.version = true;
      return options;
    }
    // unknown before missing: "--bogus" is unknown, not short of a value
    if (std::find(std::begin(kValueOptions), std::end(kValueOptions), option) == std::end(kValueOptions)) {
      throw OptionsError(option.starts_with("-") ? fmt::format("unknown option \"{}\" (see --help)", option)
                                                 : fmt::format("unexpected argument \"{}\"", option));
    }
    if (i + 1 >= args.size()) throw OptionsError(fmt::format("{} needs a value", option));
    const std::string_view value = args[++i];
    if (option == "--host") {
      options.host = value;
    } else if (option == "--tcp-port") {
      options.tcp_port = ReadInt(option, value, 0, 65535);
    } else if (option == "--udp-port") {
      options.udp_port = ReadInt(option, value, 0, 65535);
    } else if (option == "--scene") {
      options.scene_file = value;
    } else if (option == "--ray-backend") {
      if (value == "native") {
        options.ray_backend = scene::RayBackend::kNative;
      } else if (value == "embree") {
        options.ray_backend = scene::RayBackend::kEmbree;
      } else {
        throw OptionsError(fmt::format("--ray-backend is \"{}\"; it must be native or embree", value));
      }
    } else if (option == "--max-sessions") {
      options.max_sessions = ReadInt(option, value, 1, net::kMaxSessions);
    } else if (option == "--realtime-priority") {
      options.realtime_priority = ReadInt(option, value, 0, 99);
    } else if (option == "--tls-cert") {
      options.tls_certificate = value;
    } else if (option == "--tls-key") {
      options.tls_key = value;
    } else if (option == "--access-token-file") {
      options.access_token_file = value;
    } else if (option == "--observer-token-file") {
      options.observer_token_file = value;
    } else if (option == "--log-level") {
      options.log_level = net::ParseLogLevel(value);
      if (options.log_level == net::LogLevel::kCount) {
        throw OptionsError(fmt::format("--log-level is \"{}\"; it must be debug, info, warning or error", value));
      }
    } else if (option == "--max-objects") {
      options.scene_budgets.max_objects = ReadCount(option, value, 1 << 16);
    } else if (option == "--max-mesh-triangles") {
      options.scene_budgets.max_triangles_per_mesh = ReadCount(option, value, std::size_t{1} << 28);
    } else if (option == "--max-scene-triangles") {
      options.scene_budgets.max_triangles = ReadCount(option, value, std::size_t{1} << 30);
    } else if (option == "--max-connections") {
      options.max_connections = ReadCount(option, value, 1 << 14);
    } else if (option == "--max-request-bytes") {
      options.max_request_bytes = ReadInt<uint32_t>(option, value, 4096, net::kMaxFrameSize);
    } else if (option == "--tick-work-budget") {
      options.tick_work_budget = ReadInt<int64_t>(option, value, int64_t{100}, int64_t{10'000'000});
    } else if (option == "--max-request-work") {
      options.max_request_work = ReadInt<int64_t>(option, value, int64_t{10'000}, int64_t{1'000'000'000'000});
    } else {
      options.idle_timeout_s = ReadInt(option, value, 1, 24 * 3600);
    }
  }

  // The address must parse, and leaving loopback needs TLS and a token.
  std::error_code error;
  const auto address = asio::ip::make_address(options.host, error);
  if (error) throw OptionsError(fmt::format("--host is \"{}\"; it is not an IP address", options.host));
  if (!options.observer_token_file.empty() && options.access_token_file.empty()) {
    throw OptionsError("--observer-token-file needs --access-token-file (the operator's token)");
  }
  if (options.tls_certificate.empty() != options.tls_key.empty()) {
    throw OptionsError("--tls-cert and --tls-key go together; give both or neither");
  }
  if (!address.is_loopback() && (options.tls_certificate.empty() || options.access_token_file.empty())) {
    throw OptionsError(fmt::format("--host is {}, not loopback: the control channel then needs TLS "
                                   "(--tls-cert, --tls-key) and an access token (--access-token-file)",
                                   options.host));
  }
  return options;
}

}  // namespace hapticd::app
