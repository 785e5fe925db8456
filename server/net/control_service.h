#pragma once
// The control channel's requests, served against the scene and the session table
// (sans-I/O: a parsed Request in, a Reply out; control_server.h moves the bytes).
// Runs on the control thread only. Scene edits build a new snapshot with the scene
// builder and publish it; the realtime thread picks it up at its next batch.
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <vector>
#include "hapticd/v1/hapticd.pb.h"
#include "server/net/realtime_channel.h"
#include "server/net/session_table.h"
#include "server/scene/scene_builder.h"
#include "server/scene/snapshot_publisher.h"

namespace hapticd::net {

// A telemetry stream a connection asked for.
struct Subscription {
  uint64_t id = 0;  // the Subscribe's request_id
  double rate_hz = 0;
  std::vector<uint32_t> session_ids;  // empty: all
};

// What a connection may do: an operator everything, an observer only what reads.
enum class Role { kOperator, kObserver };

// What the service knows about the connection a request came on.
struct ConnectionState {
  uint64_t id = 0;  // unique per connection (the transport numbers them from 1); owns sessions
  Role role = Role::kOperator;
  // Loopback connections start authenticated when the server has no access token;
  // otherwise a Hello with the token authenticates.
  bool authenticated = false;
  bool said_hello = false;  // a Hello succeeded: the connection may send full-size frames
  // Set by Handle when its reply must be the connection's last (a failed Hello).
  bool close_after_reply = false;
  std::map<uint64_t, Subscription> subscriptions;
  // Set by Handle when a Subscribe or Unsubscribe changed `subscriptions`.
  bool subscriptions_changed = false;
};

// The transport's counts, kept here so that stats and telemetry report them.
struct ConnectionCounters {
  uint64_t open = 0;
  uint64_t refused = 0;
  uint64_t timed_out = 0;
  uint64_t hello_failures = 0;
};

// The default of --max-request-work: about 3 s of the control thread on this project's
// 2-core machine (a million rays at a hull of 327,680 faces were refused after 2.9 s);
// a million rays at a mesh of 1.3M triangles take 15 million units, a hundred thousand
// closest points on it 7 million.
inline constexpr int64_t kDefaultMaxRequestWork = 100'000'000;

struct ServiceOptions {
  std::string server_name = "hapticd";
  std::string udp_endpoint;  // "host:port" given to devices
  std::string access_token;  // the operator's; required in Hello when a connection is not authenticated
  std::string observer_token;  // optional, with access_token: a Hello with it makes an observer
  int max_subscriptions_per_connection = 16;
  // Work units one render tick may spend (geometry::WorkMeter; --tick-work-budget).
  int64_t tick_work_budget = force::kDefaultTickWorkBudget;
  // Work units one query request may spend on the control thread (--max-request-work);
  // over it the request is refused, RESOURCE_EXHAUSTED.
  int64_t max_request_work = kDefaultMaxRequestWork;
};

// The most edits one EditScene may hold.
inline constexpr int kMaxEditsPerBatch = 100'000;

class ControlService {
 public:
  // The service serves the scene `initial` (published as version 1 by the caller).
  ControlService(scene::SceneBuilder initial, scene::SnapshotPublisher& publisher, SessionTable& sessions,
                 const RealtimeCounters& realtime, ServiceOptions options);

  // Serves one request; never throws: any failure is an Error reply naming the problem.
  v1::Reply Handle(const v1::Request& request, ConnectionState& connection);
  // An Error reply to a request that could not even be parsed.
  v1::Reply MakeError(uint64_t request_id, v1::Error::Code code, const std::string& message);

  // A telemetry sample for subscription, now.
  v1::Telemetry BuildTelemetry(const Subscription& subscription);
  // Frees the slots of sessions the realtime thread handed back (closed or timed out),
  // logging each. Call often (each request and from a timer). Returns whether a session
  // is still live.
  bool ReclaimSessions();
  // The connection closed: its sessions live on, closable from now on only with their key.
  void ConnectionClosed(uint64_t connection_id);
  // Moves kinematic objects by their velocities over dt (s) and publishes the scene when
  // any moved. Call each millisecond while scene_moving() (the server's kinematics timer).
  void AdvanceKinematic(double dt);
  // Whether some kinematic object has a velocity.
  bool scene_moving() const { return builder_.HasMovingObjects(); }
  // start() is called after each edit that leaves the scene moving (the server starts its
  // kinematics timer, if it is not running).
  void OnSceneMoving(std::function<void()> start) { on_scene_moving_ = std::move(start); }
  // opened(local_model) is called after each session opens (the server's timers for
  // live sessions start: housekeeping at its fast pace, the model feed for a local-model
  // session).
  void OnSessionOpened(std::function<void(bool local_model)> opened) { on_session_opened_ = std::move(opened); }

  const ServiceOptions& options() const { return options_; }
  // Control thread only: the transport counts its connections here.
  ConnectionCounters& connection_counters() { return connection_counters_; }

 private:
  v1::Reply Dispatch(const v1::Request& request, ConnectionState& connection);
  void PublishScene();
  v1::Reply OpenSession(const v1::OpenSession& open, const ConnectionState& connection);
  v1::Reply CloseSession(const v1::CloseSession& close, const ConnectionState& connection);
  v1::Reply RayCast(const v1::RayCast& ray);
  v1::Reply ClosestPoint(const v1::ClosestPoint& query);
  v1::Reply FindContacts(const v1::FindContacts& query);
  v1::Reply Subscribe(uint64_t id, const v1::Subscribe& subscribe, ConnectionState& connection);
  v1::Reply Done();
  // Applies every edit to a copy of the builder, then keeps the copy and publishes.
  v1::Reply EditScene(const v1::EditScene& edit);
  void WriteCounters(v1::ServerCounters* out) const;
  void WriteSession(uint32_t id, const SessionTelemetrySample& sample, v1::SessionTelemetry* out) const;

  scene::SceneBuilder builder_;
  std::function<void()> on_scene_moving_;
  std::function<void(bool)> on_session_opened_;
  scene::SnapshotPublisher& publisher_;
  SessionTable& sessions_;
  const RealtimeCounters& realtime_;
  ServiceOptions options_;
  uint64_t scene_version_ = 1;
  uint64_t sessions_opened_ = 0;
  uint64_t sessions_closed_ = 0;
  uint64_t control_errors_ = 0;
  ConnectionCounters connection_counters_;
  // Sessions reclaimed lately, reported in telemetry for a while so no subscriber misses
  // how a session ended.
  struct EndedSession {
    uint32_t id;
    int64_t ended_ns;
    SessionTelemetrySample last;
  };
  std::deque<EndedSession> ended_;
};

}  // namespace hapticd::net
