#include "server/app/server.h"

#include <csignal>
#include <fstream>

#include <asio/io_context.hpp>
#include <asio/post.hpp>
#include <asio/signal_set.hpp>
#include <asio/steady_timer.hpp>
#include <fmt/format.h>

#include "server/net/control_server.h"
#include "server/net/control_service.h"
#include "server/net/log.h"
#include "server/net/model_feed.h"
#include "server/net/realtime_channel.h"

namespace hapticd::app {
namespace {

using namespace std::chrono_literals;
using net::Log;
using net::LogLevel;

// Reader slots: the realtime thread, plus room to grow.
constexpr int kSnapshotReaders = 4;

std::string FormatEndpoint(const asio::ip::address& address, unsigned short port) {
  return address.is_v6() ? fmt::format("[{}]:{}", address.to_string(), port)
                         : fmt::format("{}:{}", address.to_string(), port);
}

std::string ReadToken(const std::string& path) {
  std::ifstream file(path);
  std::string token;
  if (!file || !std::getline(file, token)) {
    throw std::runtime_error(fmt::format("the token file {} cannot be read", path));
  }
  if (token.size() < 16) {
    throw std::runtime_error(fmt::format("the access token in {} has {} characters; use at least 16", path,
                                         token.size()));
  }
  return token;
}

}  // namespace

struct Server::Impl {
  Impl(const ServerOptions& options, scene::SceneBuilder initial)
      : publisher(initial.Build(1), kSnapshotReaders),
        sessions(options.max_sessions),
        realtime(asio::ip::udp::endpoint(asio::ip::make_address(options.host),
                                         static_cast<unsigned short>(options.udp_port)),
                 sessions, publisher),
        service(std::move(initial), publisher, sessions, realtime.counters(), MakeServiceOptions(options)),
        control(context, service, MakeControlOptions(options)),
        models(sessions, publisher),
        housekeeping(context),
        kinematics(context),
        model_timer(context),
        signals(context, SIGINT, SIGTERM) {}

  net::ServiceOptions MakeServiceOptions(const ServerOptions& options) {
    net::ServiceOptions service_options;
    service_options.tick_work_budget = options.tick_work_budget;
    service_options.max_request_work = options.max_request_work;
    service_options.udp_endpoint =
        FormatEndpoint(realtime.local_endpoint().address(), realtime.local_endpoint().port());
    if (!options.access_token_file.empty()) service_options.access_token = ReadToken(options.access_token_file);
    if (!options.observer_token_file.empty()) {
      service_options.observer_token = ReadToken(options.observer_token_file);
      if (service_options.observer_token == service_options.access_token) {
        throw std::runtime_error("--observer-token-file holds the operator's token; give observers their own");
      }
    }
    return service_options;
  }

  static net::ControlServerOptions MakeControlOptions(const ServerOptions& options) {
    net::ControlServerOptions control_options;
    control_options.endpoint = asio::ip::tcp::endpoint(asio::ip::make_address(options.host),
                                                       static_cast<unsigned short>(options.tcp_port));
    if (!options.tls_certificate.empty()) control_options.tls = net::TlsFiles{options.tls_certificate, options.tls_key};
    control_options.max_connections = options.max_connections;
    control_options.max_frame_bytes = options.max_request_bytes;
    control_options.idle_timeout = std::chrono::seconds(options.idle_timeout_s);
    return control_options;
  }

  // Every millisecond while some kinematic object has a velocity: they move by it (a
  // new snapshot each time), over the time that really passed. A scene at rest wakes
  // nobody; the edit that sets something moving starts the timer again.
  void StartKinematics() {
    if (kinematics_running || stopping) return;
    kinematics_running = true;
    last_kinematics = std::chrono::steady_clock::now();
    kinematics.expires_at(last_kinematics);
    MoveKinematics();
  }

  void MoveKinematics() {
    kinematics.expires_at(kinematics.expiry() + 1ms);
    kinematics.async_wait([this](std::error_code error) {
      if (error || stopping) return;
      const auto now = std::chrono::steady_clock::now();
      const double dt = std::chrono::duration<double>(now - last_kinematics).count();
      last_kinematics = now;
      service.AdvanceKinematic(dt);
      if (!service.scene_moving()) {
        kinematics_running = false;
        return;
      }
      MoveKinematics();
    });
  }

  // The local models (net/model_feed.h): a pass every 2 ms while a local-model session
  // lives. Without one the feed sleeps; opening one starts it, with a pass right after
  // the open's reply.
  void StartModelFeed() {
    if (feeding_models || stopping) return;
    feeding_models = true;
    asio::post(context, [this] {
      if (!stopping) FeedModels();
    });
  }

  void FeedModels() {
    if (!models.Pass(net::MonotonicNowNs())) {
      feeding_models = false;
      return;
    }
    model_timer.expires_after(2ms);
    model_timer.async_wait([this](std::error_code error) {
      if (error || stopping) return;
      FeedModels();
    });
  }

  // Every 50 ms while a session lives: hand back finished sessions' slots (each request
  // does too); with none, every 5 s, the drop report's own pace (opening one brings the
  // fast pace back). At most every 5 s: report the realtime thread's drop counters when
  // they grew (it cannot log itself).
  void Housekeep(bool sessions_live) {
    housekeeping.expires_after(sessions_live ? 50ms : 5s);
    housekeeping.async_wait([this](std::error_code error) {
      if (error || stopping) return;
      const bool live = service.ReclaimSessions();
      const auto now = std::chrono::steady_clock::now();
      if (now - last_drop_report >= 5s) {
        ReportDrops();
        last_drop_report = now;
      }
      Housekeep(live);
    });
  }

  // A session opened: housekeeping at its fast pace (the wait under way is cancelled),
  // and the model feed for a local-model session.
  void SessionOpened(bool local_model) {
    Housekeep(true);
    if (local_model) StartModelFeed();
  }

  void ReportDrops() {
    const auto& c = realtime.counters();
    const uint64_t dropped = c.malformed + c.oversized + c.unknown_session + c.bad_tag + c.replayed + c.reordered;
    if (dropped == reported_drops && c.send_errors == reported_send_errors) return;
    Log(LogLevel::kWarning,
        "realtime drops so far: {} malformed, {} oversized, {} unknown session, {} bad tag, {} replayed, "
        "{} reordered; {} send errors",
        c.malformed.load(), c.oversized.load(), c.unknown_session.load(), c.bad_tag.load(), c.replayed.load(),
        c.reordered.load(), c.send_errors.load());
    reported_drops = dropped;
    reported_send_errors = c.send_errors;
  }

  asio::io_context context;
  scene::SnapshotPublisher publisher;
  net::SessionTable sessions;
  net::RealtimeChannel realtime;
  net::ControlService service;
  net::ControlServer control;
  net::ModelFeed models;
  asio::steady_timer housekeeping;
  asio::steady_timer kinematics;
  asio::steady_timer model_timer;
  std::chrono::steady_clock::time_point last_kinematics;
  bool kinematics_running = false;
  bool feeding_models = false;
  asio::signal_set signals;
  // Set on SIGINT/SIGTERM: a timer whose handler was already due when it was cancelled
  // must not arm itself again, or the io_context would never run out of work.
  bool stopping = false;
  std::chrono::steady_clock::time_point last_drop_report = std::chrono::steady_clock::now();
  uint64_t reported_drops = 0;
  uint64_t reported_send_errors = 0;
};

Server::Server(const ServerOptions& options, scene::SceneBuilder initial)
    : impl_(std::make_unique<Impl>(options, std::move(initial))),
      realtime_priority_(options.realtime_priority) {}

Server::~Server() = default;

std::string Server::EndpointsJson() const {
  const auto tcp = impl_->control.local_endpoint();
  const auto udp = impl_->realtime.local_endpoint();
  return fmt::format(R"({{"tcp": "{}", "udp": "{}"}})", FormatEndpoint(tcp.address(), tcp.port()),
                     FormatEndpoint(udp.address(), udp.port()));
}

void Server::Run() {
  Impl& impl = *impl_;
  impl.signals.async_wait([&impl](std::error_code error, int signal) {
    if (error) return;
    Log(LogLevel::kInfo, "{} received; stopping", signal == SIGINT ? "SIGINT" : "SIGTERM");
    impl.stopping = true;
    impl.housekeeping.cancel();
    impl.kinematics.cancel();
    impl.model_timer.cancel();
    impl.control.Stop();
    impl.realtime.Stop();
  });
  const bool prioritized = impl.realtime.Start(realtime_priority_);
  if (realtime_priority_ > 0) {
    Log(LogLevel::kInfo, "the realtime thread runs at {}", prioritized
            ? fmt::format("SCHED_FIFO priority {}", realtime_priority_)
            : fmt::format("normal priority (SCHED_FIFO {} was not granted)", realtime_priority_));
  }
  impl.control.Start();
  impl.Housekeep(false);
  impl.service.OnSessionOpened([&impl](bool local_model) { impl.SessionOpened(local_model); });
  impl.service.OnSceneMoving([&impl] { impl.StartKinematics(); });
  if (impl.service.scene_moving()) impl.StartKinematics();
  Log(LogLevel::kInfo, "serving {} ({} objects, up to {} sessions)", EndpointsJson(),
      impl.publisher.current()->num_objects(), impl.sessions.capacity());
  impl.context.run();
  impl.realtime.Stop();
  Log(LogLevel::kInfo, "stopped after {} datagrams", impl.realtime.counters().datagrams_received.load());
}

}  // namespace hapticd::app
