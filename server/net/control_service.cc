#include "server/net/control_service.h"

#include <sodium.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "server/geometry/work_meter.h"
#include "server/net/log.h"
#include "server/net/point_batches.h"
#include "server/net/proto_convert.h"
#include "server/net/ray_batch.h"
#include "server/net/request_error.h"
#include "server/net/scene_description.h"
#include "server/query/scene_queries.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

constexpr uint32_t kProtocolVersion = 1;
// Telemetry rates: a sample at least every 10 s, at most one a millisecond.
constexpr double kMinTelemetryRateHz = 0.1;
constexpr double kMaxTelemetryRateHz = 1000;
// How long an ended session stays in telemetry after it was reclaimed.
constexpr int64_t kEndedVisibleNs = 2'000'000'000;
// At most this many ended sessions are listed, the latest: churn cannot grow a reply.
constexpr std::size_t kMaxEndedListed = 64;

// Constant-time comparison of equal-length strings; a length mismatch is a miss.
bool SameSecret(std::string_view given, std::string_view secret) {
  return !secret.empty() && given.size() == secret.size() &&
         sodium_memcmp(given.data(), secret.data(), given.size()) == 0;
}

std::string_view RoleName(Role role) { return role == Role::kObserver ? "observer" : "operator"; }

// The queries of the scene, by their request's field name; empty for any other request.
std::string_view QueryName(v1::Request::BodyCase body) {
  using R = v1::Request;
  switch (body) {
    case R::kRayCast: return "ray_cast";
    case R::kRayCastBatch: return "ray_cast_batch";
    case R::kClosestPoint: return "closest_point";
    case R::kFindContacts: return "find_contacts";
    case R::kClosestPointBatch: return "closest_point_batch";
    case R::kFindContactsBatch: return "find_contacts_batch";
    default: return {};
  }
}

// Whether an observer may make this request: only those that read.
bool IsReadOnly(v1::Request::BodyCase body) {
  using R = v1::Request;
  switch (body) {
    case R::kHello:
    case R::kGetScene:
    case R::kRayCast:
    case R::kRayCastBatch:
    case R::kClosestPoint:
    case R::kFindContacts:
    case R::kClosestPointBatch:
    case R::kFindContactsBatch:
    case R::kSubscribe:
    case R::kUnsubscribe:
    case R::kGetStats:
      return true;
    default:
      return false;
  }
}

v1::SessionState ToProto(SlotState state) {
  switch (state) {
    case SlotState::kWaiting: return v1::SESSION_STATE_WAITING;
    case SlotState::kActive: return v1::SESSION_STATE_ACTIVE;
    case SlotState::kRamping: return v1::SESSION_STATE_RAMPING;
    case SlotState::kClosed: return v1::SESSION_STATE_CLOSED;
    case SlotState::kTimedOut: return v1::SESSION_STATE_TIMED_OUT;
    case SlotState::kFree: break;
  }
  return v1::SESSION_STATE_UNSPECIFIED;
}

std::string SessionName(uint32_t id) { return fmt::format("{:08x}", id); }

}  // namespace

ControlService::ControlService(scene::SceneBuilder initial, scene::SnapshotPublisher& publisher,
                               SessionTable& sessions, const RealtimeCounters& realtime, ServiceOptions options)
    : builder_(std::move(initial)),
      publisher_(publisher),
      sessions_(sessions),
      realtime_(realtime),
      options_(std::move(options)) {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
  scene_version_ = publisher_.current()->version();
}

v1::Reply ControlService::MakeError(uint64_t request_id, v1::Error::Code code, const std::string& message) {
  ++control_errors_;
  v1::Reply reply;
  reply.set_request_id(request_id);
  reply.mutable_error()->set_code(code);
  reply.mutable_error()->set_message(message);
  return reply;
}

v1::Reply ControlService::Handle(const v1::Request& request, ConnectionState& connection) {
  ReclaimSessions();
  try {
    // Fields this protocol version does not define mean the two sides disagree: refuse
    // the request rather than act on half of it.
    const std::string unknown = FindUnknownField(request, "request");
    if (!unknown.empty()) {
      throw BadRequest(unknown + " is not part of hapticd.v1; is the client built for another version?");
    }
    // a query's work is bounded (--max-request-work): the control thread serves every
    // client, and a batch against a hull of a million faces could hold it for minutes
    const std::string_view query = QueryName(request.body_case());
    std::optional<geometry::WorkMeter> meter;
    if (!query.empty()) meter.emplace(options_.max_request_work);
    v1::Reply reply = Dispatch(request, connection);
    if (meter && meter->exhausted()) {
      throw RequestError(v1::Error::CODE_RESOURCE_EXHAUSTED,
                         fmt::format("{} needs more than {} units of work, the most one request may take "
                                     "(--max-request-work; a unit is a BVH node, a primitive, an object or "
                                     "eight hull vertices or faces); ask it in smaller batches",
                                     query, options_.max_request_work));
    }
    reply.set_request_id(request.request_id());
    return reply;
  } catch (const RequestError& e) {
    Log(LogLevel::kDebug, "request {} refused: {}", request.request_id(), e.what());
    return MakeError(request.request_id(), e.code(), e.what());
  } catch (const scene::SceneError& e) {
    Log(LogLevel::kDebug, "request {} refused: {}", request.request_id(), e.what());
    return MakeError(request.request_id(), v1::Error::CODE_BAD_REQUEST, e.what());
  } catch (const std::exception& e) {
    Log(LogLevel::kError, "request {} failed: {}", request.request_id(), e.what());
    return MakeError(request.request_id(), v1::Error::CODE_INTERNAL, e.what());
  }
}

namespace {

void RequireObject(const scene::SceneBuilder& builder, const std::string& name, const std::string& field) {
  if (builder.FindObject(name) < 0) {
    throw RequestError(v1::Error::CODE_NOT_FOUND,
                       fmt::format("{} is \"{}\"; the scene has no object of that name", field, name));
  }
}

// A scene error names the object; in a batch, say which edit it came from.
template <typename Apply>
void NamingTheEdit(const std::string& where, Apply apply) {
  try {
    apply();
  } catch (const scene::SceneError& e) {
    if (where.starts_with("edit_scene.")) throw scene::SceneError(where + ": " + e.what());
    throw;
  }
}

void ApplyAdd(scene::SceneBuilder& builder, const v1::AddObject& add, const std::string& field) {
  const scene::ObjectSpec spec = ReadObject(add.object(), field + ".object");
  if (builder.FindObject(spec.name) >= 0) {
    throw RequestError(v1::Error::CODE_ALREADY_EXISTS,
                       fmt::format("{}.object.name is \"{}\"; an object of that name exists "
                                   "(use update_object to replace it)",
                                   field, spec.name));
  }
  NamingTheEdit(field, [&] { builder.Add(spec); });
}

void ApplyUpdate(scene::SceneBuilder& builder, const v1::UpdateObject& update,
                                 const std::string& field) {
  const scene::ObjectSpec spec = ReadObject(update.object(), field + ".object");
  RequireObject(builder, spec.name, field + ".object.name");
  NamingTheEdit(field, [&] { builder.Update(spec); });
}

void ApplyRemove(scene::SceneBuilder& builder, const v1::RemoveObject& remove,
                                 const std::string& field) {
  RequireObject(builder, remove.name(), field + ".name");
  builder.Remove(remove.name());
}

void ApplySetMaterial(scene::SceneBuilder& builder, const v1::SetMaterial& set,
                                      const std::string& field) {
  RequireObject(builder, set.name(), field + ".name");
  const scene::Material material =
      set.has_change()
          ? ReadMaterialChange(set.change(), builder.material(builder.FindObject(set.name())), field + ".change")
          : ReadMaterial(set.material(), field + ".material");
  NamingTheEdit(field, [&] { builder.SetMaterial(set.name(), material); });
}

void ApplyMoveKinematic(scene::SceneBuilder& builder, const v1::MoveKinematic& move,
                                        const std::string& field) {
  RequireObject(builder, move.name(), field + ".name");
  const scene::Pose pose = ReadPose(move.pose(), move.has_pose(), field + ".pose");
  const Vector3 velocity = ReadVector(move.velocity(), field + ".velocity");
  const Vector3 angular_velocity = ReadVector(move.angular_velocity(), field + ".angular_velocity");
  NamingTheEdit(field, [&] { builder.MoveKinematic(move.name(), pose, velocity, angular_velocity); });
}

}  // namespace

v1::Reply ControlService::Dispatch(const v1::Request& request, ConnectionState& connection) {
  using R = v1::Request;
  // Off loopback, nothing but a Hello with the token until one succeeded.
  if (!connection.authenticated && request.body_case() != R::kHello) {
    throw RequestError(v1::Error::CODE_UNAUTHENTICATED,
                       "this connection must send a Hello with the server's access token first");
  }
  if (connection.role == Role::kObserver && !IsReadOnly(request.body_case())) {
    const auto* field = v1::Request::descriptor()->FindFieldByNumber(static_cast<int>(request.body_case()));
    throw RequestError(v1::Error::CODE_PERMISSION_DENIED,
                       fmt::format("{} needs the operator's token; this connection's role is observer",
                                   field != nullptr ? field->name() : "this request"));
  }
  switch (request.body_case()) {
    case R::kHello: {
      // A failed Hello is the connection's last request: the transport closes it after
      // the error (and counts the failure against the peer's address).
      const v1::Hello& hello = request.hello();
      if (hello.protocol_version() != kProtocolVersion) {
        connection.close_after_reply = true;
        ++connection_counters_.hello_failures;
        throw BadRequest(fmt::format("hello.protocol_version is {}; this server speaks {}",
                                     hello.protocol_version(), kProtocolVersion));
      }
      // With a token configured every Hello must carry one, on loopback too; which one
      // sets the connection's role.
      if (!options_.access_token.empty() || !connection.authenticated) {
        const std::string& token = hello.access_token();
        if (SameSecret(token, options_.access_token)) {
          connection.role = Role::kOperator;
        } else if (SameSecret(token, options_.observer_token)) {
          connection.role = Role::kObserver;
        } else {
          connection.close_after_reply = true;
          ++connection_counters_.hello_failures;
          throw RequestError(v1::Error::CODE_UNAUTHENTICATED,
                             "hello.access_token is not this server's token; closing the connection");
        }
        connection.authenticated = true;
      }
      connection.said_hello = true;
      v1::Reply reply;
      reply.mutable_hello()->set_protocol_version(kProtocolVersion);
      reply.mutable_hello()->set_server_name(options_.server_name);
      reply.mutable_hello()->set_udp_endpoint(options_.udp_endpoint);
      reply.mutable_hello()->set_role(std::string(RoleName(connection.role)));
      return reply;
    }
    case R::kOpenSession: return OpenSession(request.open_session(), connection);
    case R::kCloseSession: return CloseSession(request.close_session(), connection);
    case R::kAddObject:
      ApplyAdd(builder_, request.add_object(), "add_object");
      PublishScene();
      return Done();
    case R::kUpdateObject:
      ApplyUpdate(builder_, request.update_object(), "update_object");
      PublishScene();
      return Done();
    case R::kRemoveObject:
      ApplyRemove(builder_, request.remove_object(), "remove_object");
      PublishScene();
      return Done();
    case R::kSetMaterial:
      ApplySetMaterial(builder_, request.set_material(), "set_material");
      PublishScene();
      return Done();
    case R::kMoveKinematic:
      ApplyMoveKinematic(builder_, request.move_kinematic(), "move_kinematic");
      PublishScene();
      return Done();
    case R::kEditScene: return EditScene(request.edit_scene());
    case R::kClearScene:
      builder_ = scene::SceneBuilder(builder_.settings());
      PublishScene();
      return Done();
    case R::kGetScene: {
      v1::Reply reply;
      *reply.mutable_scene() = DescribeScene(*publisher_.current(), request.get_scene());
      return reply;
    }
    case R::kRayCast: return RayCast(request.ray_cast());
    case R::kRayCastBatch: {
      v1::Reply reply;
      *reply.mutable_ray_hits() = CastRayBatch(*publisher_.current(), request.ray_cast_batch());
      return reply;
    }
    case R::kClosestPoint: return ClosestPoint(request.closest_point());
    case R::kFindContacts: return FindContacts(request.find_contacts());
    case R::kClosestPointBatch: {
      v1::Reply reply;
      *reply.mutable_closest_points() = FindClosestPointBatch(*publisher_.current(), request.closest_point_batch());
      return reply;
    }
    case R::kFindContactsBatch: {
      v1::Reply reply;
      *reply.mutable_contacts_batch() = FindBatchContacts(*publisher_.current(), request.find_contacts_batch());
      return reply;
    }
    case R::kSubscribe: return Subscribe(request.request_id(), request.subscribe(), connection);
    case R::kUnsubscribe: {
      const uint64_t id = request.unsubscribe().subscription_id();
      if (connection.subscriptions.erase(id) == 0) {
        throw RequestError(v1::Error::CODE_NOT_FOUND,
                           fmt::format("unsubscribe.subscription_id is {}; this connection has no such "
                                       "subscription",
                                       id));
      }
      connection.subscriptions_changed = true;
      return Done();
    }
    case R::kGetStats: {
      const Subscription everything;
      const v1::Telemetry telemetry = BuildTelemetry(everything);
      v1::Reply reply;
      v1::Stats* stats = reply.mutable_stats();
      stats->set_scene_version(telemetry.scene_version());
      *stats->mutable_sessions() = telemetry.sessions();
      *stats->mutable_counters() = telemetry.counters();
      return reply;
    }
    case R::BODY_NOT_SET: break;
  }
  throw BadRequest("request has no body: it names none of the requests hapticd.v1 defines");
}

v1::Reply ControlService::EditScene(const v1::EditScene& edit) {
  if (edit.edits_size() > kMaxEditsPerBatch) {
    throw BadRequest(fmt::format("edit_scene has {} edits; at most {} are served in one request",
                                 edit.edits_size(), kMaxEditsPerBatch));
  }
  // on a copy, so that a refused edit leaves the scene as it was (the copy shares the
  // objects and the broad phase; what an edit changes is copied on write)
  scene::SceneBuilder staged = builder_;
  for (int i = 0; i < edit.edits_size(); ++i) {
    const v1::SceneEdit& one = edit.edits(i);
    const std::string field = fmt::format("edit_scene.edits[{}].", i);
    switch (one.edit_case()) {
      case v1::SceneEdit::kAddObject: ApplyAdd(staged, one.add_object(), field + "add_object"); break;
      case v1::SceneEdit::kUpdateObject: ApplyUpdate(staged, one.update_object(), field + "update_object"); break;
      case v1::SceneEdit::kRemoveObject: ApplyRemove(staged, one.remove_object(), field + "remove_object"); break;
      case v1::SceneEdit::kSetMaterial: ApplySetMaterial(staged, one.set_material(), field + "set_material"); break;
      case v1::SceneEdit::kMoveKinematic:
        ApplyMoveKinematic(staged, one.move_kinematic(), field + "move_kinematic");
        break;
      case v1::SceneEdit::EDIT_NOT_SET:
        throw BadRequest(fmt::format("edit_scene.edits[{}] is empty; it needs one of add_object, "
                                     "update_object, remove_object, set_material, move_kinematic",
                                     i));
    }
  }
  builder_ = std::move(staged);
  PublishScene();
  return Done();
}

void ControlService::PublishScene() {
  publisher_.Publish(builder_.Build(++scene_version_));
  if (on_scene_moving_ && builder_.HasMovingObjects()) on_scene_moving_();
  Log(LogLevel::kDebug, "scene version {} published ({} objects)", scene_version_, builder_.num_objects());
}

v1::Reply ControlService::Done() {
  v1::Reply reply;
  reply.mutable_done()->set_scene_version(scene_version_);
  return reply;
}

v1::Reply ControlService::OpenSession(const v1::OpenSession& open, const ConnectionState& connection) {
  Vector3 start_W;
  double timeout_s = 0;
  const force::SessionSettings settings = ReadSessionRequest(open, start_W, timeout_s);
  const bool local_model = ReadLocalModelMode(open);
  const ChannelRequest channel = ReadChannelRequest(open);
  const int index = sessions_.FindFree();
  if (index < 0) {
    throw RequestError(v1::Error::CODE_RESOURCE_EXHAUSTED,
                       fmt::format("all {} session slots are in use", sessions_.capacity()));
  }
  const uint32_t id = sessions_.MakeId(index);

  // Fill the free slot, then hand it to the realtime thread with one release store.
  SessionSlot& slot = sessions_.slot(index);
  slot.id = id;
  slot.SetKey(MakeSessionKey());
  slot.owner_connection = connection.id;
  slot.period_ns = static_cast<int64_t>(std::llround(1e9 / settings.device.rate_hz));
  slot.timeout_ns = static_cast<int64_t>(std::llround(timeout_s * 1e9));
  slot.render.emplace(settings, options_.tick_work_budget);
  slot.render->Reset(start_W);
  slot.start_W = start_W;
  slot.local_model = local_model;
  if (local_model && !slot.models) slot.models = std::make_unique<ModelMailbox>();
  slot.sending_version = 0;
  slot.next_fragment = 0;
  slot.fragments_sent = 0;
  slot.channel = remote::RendererChannel(channel.tdpa, channel.deadband, local_model);
  slot.channel.Reset(start_W);
  slot.state_sequence = 0;
  slot.state_send_ns = 0;
  slot.command_number = 0;
  slot.replay.Reset();
  slot.peer_size = 0;
  slot.opened_ns = MonotonicNowNs();
  slot.last_state_ns = slot.opened_ns;
  slot.last_send_ns = 0;
  slot.next_silent_tick_ns = slot.opened_ns;
  slot.last_input = force::DeviceInput{};
  slot.last_input.p_WD = start_W;
  slot.ramp_done = false;
  slot.telemetry = SessionTelemetrySample{};
  slot.telemetry.state = SlotState::kWaiting;
  slot.telemetry.p_WD = start_W;
  slot.telemetry.avatar_W = start_W;
  slot.published.Write(slot.telemetry);
  slot.close_requested.store(false, std::memory_order_relaxed);
  sessions_.MarkOpened(index);
  slot.state.store(SlotState::kWaiting, std::memory_order_release);
  sessions_.Ring();  // the realtime thread may be asleep without a timeout
  ++sessions_opened_;
  if (on_session_opened_) on_session_opened_(local_model);
  Log(LogLevel::kInfo, "session {} opened: {} {} avatar, {}, {} Hz, max force {} N{}{}{}", SessionName(id),
      force::DeviceModeName(settings.device.mode), force::AvatarTypeName(settings.avatar.type),
      force::ForceMethodName(settings.avatar.method), settings.device.rate_hz, settings.device.max_force,
      local_model ? ", rendered on the device from local models" : "", channel.tdpa ? ", two-port passivity" : "",
      channel.deadband.on() ? fmt::format(", deadband {}", channel.deadband.weber) : std::string());

  v1::Reply reply;
  v1::SessionOpened* opened = reply.mutable_session_opened();
  opened->set_session_id(id);
  opened->set_session_key(std::string(slot.key.begin(), slot.key.end()));
  opened->set_udp_endpoint(options_.udp_endpoint);
  opened->set_max_datagram(static_cast<uint32_t>(kMaxStateSize));
  return reply;
}

v1::Reply ControlService::CloseSession(const v1::CloseSession& close, const ConnectionState& connection) {
  const int index = sessions_.FindById(close.session_id());
  if (index < 0 || !IsLive(sessions_.slot(index).state.load(std::memory_order_acquire))) {
    throw RequestError(v1::Error::CODE_NOT_FOUND,
                       fmt::format("close_session.session_id is {}; no open session has that id",
                                   SessionName(close.session_id())));
  }
  SessionSlot& slot = sessions_.slot(index);
  // its own connection, or whoever holds its key (the same client, reconnected)
  const bool owner = slot.owner_connection != 0 && slot.owner_connection == connection.id;
  const std::string_view key(reinterpret_cast<const char*>(slot.key.data()), slot.key.size());
  if (!owner && !SameSecret(close.session_key(), key)) {
    throw RequestError(v1::Error::CODE_PERMISSION_DENIED,
                       fmt::format("close_session.session_id is {}; another connection opened it, so closing it "
                                   "here needs its session_key",
                                   SessionName(close.session_id())));
  }
  slot.close_requested.store(true, std::memory_order_release);
  return Done();
}

void ControlService::AdvanceKinematic(double dt) {
  if (builder_.AdvanceKinematic(dt)) PublishScene();
}

void ControlService::ConnectionClosed(uint64_t connection_id) {
  if (connection_id == 0) return;
  for (int i = 0; i < sessions_.capacity(); ++i) {
    SessionSlot& slot = sessions_.slot(i);
    if (slot.owner_connection == connection_id) slot.owner_connection = 0;
  }
}

bool ControlService::ReclaimSessions() {
  const int64_t now_ns = MonotonicNowNs();
  bool any_live = false;
  // slots past used_slots() were never opened: nothing there to hand back
  for (int i = 0; i < sessions_.used_slots(); ++i) {
    SessionSlot& slot = sessions_.slot(i);
    const SlotState state = slot.state.load(std::memory_order_acquire);
    any_live = any_live || IsLive(state);
    if (state != SlotState::kClosed && state != SlotState::kTimedOut) continue;
    const SessionTelemetrySample last = slot.published.Read();
    if (state == SlotState::kClosed) {
      ++sessions_closed_;
      Log(LogLevel::kInfo, "session {} closed after {} states", SessionName(slot.id), last.states_received);
    } else {
      Log(LogLevel::kWarning, "session {} timed out: no state for {} s; its force was ramped to zero",
          SessionName(slot.id), static_cast<double>(slot.timeout_ns) * 1e-9);
    }
    // Report drops the realtime thread could only count.
    if (last.bad_tag || last.replayed || last.reordered || last.render.nonfinite_inputs) {
      Log(LogLevel::kInfo, "session {} dropped {} bad-tag, {} replayed, {} reordered states; {} non-finite",
          SessionName(slot.id), last.bad_tag, last.replayed, last.reordered, last.render.nonfinite_inputs);
    }
    ended_.push_back({slot.id, now_ns, last});
    slot.state.store(SlotState::kFree, std::memory_order_release);
  }
  while (!ended_.empty() &&
         (now_ns - ended_.front().ended_ns > kEndedVisibleNs || ended_.size() > kMaxEndedListed)) {
    ended_.pop_front();
  }
  return any_live;
}

v1::Reply ControlService::RayCast(const v1::RayCast& ray) {
  const Vector3 origin = ReadVector(ray.origin(), "ray_cast.origin");
  const Vector3 direction = ReadVector(ray.direction(), "ray_cast.direction");
  if (!(direction.norm() > 0)) throw BadRequest("ray_cast.direction is zero; it needs a direction");
  const double length = RequirePositive(ray.max_distance(), "ray_cast.max_distance");
  const auto snapshot = publisher_.current();
  const Vector3 end = origin + direction.normalized() * length;
  const query::SceneSweep sweep = query::SweepSphereScene(*snapshot, origin, end, 0);
  v1::Reply reply;
  v1::RayHit* hit = reply.mutable_ray_hit();
  hit->set_hit(sweep.hit);
  if (sweep.hit) {
    hit->set_distance(sweep.t * length);
    WriteVector(sweep.point_W, hit->mutable_point());
    WriteVector(sweep.normal_W, hit->mutable_normal());
    hit->set_object(snapshot->object(sweep.object).name);
  }
  return reply;
}

v1::Reply ControlService::ClosestPoint(const v1::ClosestPoint& query) {
  const Vector3 p_W = ReadVector(query.point(), "closest_point.point");
  const double max_distance = RequirePositive(query.max_distance(), "closest_point.max_distance");
  const auto snapshot = publisher_.current();
  const query::SceneContact contact = query::FindDeepestContact(*snapshot, p_W, 0, max_distance);
  v1::Reply reply;
  v1::ClosestPointResult* result = reply.mutable_closest_point();
  result->set_found(contact.object >= 0);
  if (contact.object >= 0) {
    result->set_signed_distance(-contact.depth);
    WriteVector(contact.point_W, result->mutable_point());
    WriteVector(contact.normal_W, result->mutable_normal());
    result->set_object(snapshot->object(contact.object).name);
  }
  return reply;
}

v1::Reply ControlService::FindContacts(const v1::FindContacts& query) {
  const Vector3 c_W = ReadVector(query.center(), "find_contacts.center");
  const double r = query.radius();
  if (!(std::isfinite(r) && r >= 0)) {
    throw BadRequest(fmt::format("find_contacts.radius is {}; it must be a finite number >= 0", r));
  }
  const auto snapshot = publisher_.current();
  v1::Reply reply;
  v1::ContactsResult* result = reply.mutable_contacts();
  for (const query::SceneContact& found : query::FindObjectContacts(*snapshot, c_W, r)) {
    v1::Contact* contact = result->add_contacts();
    contact->set_object(snapshot->object(found.object).name);
    WriteVector(found.point_W, contact->mutable_point());
    WriteVector(found.normal_W, contact->mutable_normal());
    contact->set_depth(found.depth);
  }
  return reply;
}

v1::Reply ControlService::Subscribe(uint64_t id, const v1::Subscribe& subscribe, ConnectionState& connection) {
  const double rate_hz =
      RequireInRange(subscribe.rate_hz(), kMinTelemetryRateHz, kMaxTelemetryRateHz, "subscribe.rate_hz");
  if (connection.subscriptions.count(id)) {
    throw RequestError(v1::Error::CODE_ALREADY_EXISTS,
                       fmt::format("request_id {} already names a subscription on this connection", id));
  }
  if (static_cast<int>(connection.subscriptions.size()) >= options_.max_subscriptions_per_connection) {
    throw RequestError(v1::Error::CODE_RESOURCE_EXHAUSTED,
                       fmt::format("this connection has {} subscriptions, the most allowed",
                                   connection.subscriptions.size()));
  }
  // each session named must be open or lately ended: a typo would watch nothing for ever
  for (int i = 0; i < subscribe.session_ids_size(); ++i) {
    const uint32_t session = subscribe.session_ids(i);
    const int index = sessions_.FindById(session);
    const bool open = index >= 0 && sessions_.slot(index).state.load(std::memory_order_acquire) != SlotState::kFree;
    const bool ended = std::any_of(ended_.begin(), ended_.end(), [&](const EndedSession& e) { return e.id == session; });
    if (!open && !ended) {
      throw RequestError(v1::Error::CODE_NOT_FOUND,
                         fmt::format("subscribe.session_ids[{}] is {}; no session has that id", i, SessionName(session)));
    }
  }
  Subscription subscription{id, rate_hz, {subscribe.session_ids().begin(), subscribe.session_ids().end()}};
  v1::Reply reply;
  *reply.mutable_telemetry() = BuildTelemetry(subscription);
  connection.subscriptions[id] = std::move(subscription);
  connection.subscriptions_changed = true;
  return reply;
}

v1::Telemetry ControlService::BuildTelemetry(const Subscription& subscription) {
  ReclaimSessions();
  auto wanted = [&](uint32_t id) {
    const auto& ids = subscription.session_ids;
    return ids.empty() || std::find(ids.begin(), ids.end(), id) != ids.end();
  };
  v1::Telemetry telemetry;
  telemetry.set_server_time_ns(static_cast<uint64_t>(MonotonicNowNs()));
  telemetry.set_scene_version(scene_version_);
  for (int i = 0; i < sessions_.capacity(); ++i) {
    SessionSlot& slot = sessions_.slot(i);
    if (slot.state.load(std::memory_order_acquire) == SlotState::kFree || !wanted(slot.id)) continue;
    WriteSession(slot.id, slot.published.Read(), telemetry.add_sessions());
  }
  for (const EndedSession& ended : ended_) {
    if (wanted(ended.id)) WriteSession(ended.id, ended.last, telemetry.add_sessions());
  }
  WriteCounters(telemetry.mutable_counters());
  return telemetry;
}

void ControlService::WriteSession(uint32_t id, const SessionTelemetrySample& sample, v1::SessionTelemetry* out) const {
  out->set_session_id(id);
  out->set_state(ToProto(sample.state));
  WriteVector(sample.f_W, out->mutable_force());
  WriteVector(sample.p_WD, out->mutable_device_position());
  WriteVector(sample.avatar_W, out->mutable_avatar());
  out->set_contact(sample.contact);
  out->set_rtt_us(sample.rtt_us);
  out->set_last_sequence(sample.last_sequence);
  out->set_ticks(sample.render.ticks);
  out->set_states_received(sample.states_received);
  out->set_commands_sent(sample.commands_sent);
  out->set_replayed(sample.replayed);
  out->set_reordered(sample.reordered);
  out->set_bad_mac(sample.bad_tag);
  out->set_nonfinite_inputs(sample.render.nonfinite_inputs);
  out->set_absurd_inputs(sample.render.absurd_inputs);
  out->set_force_saturations(sample.render.force_saturations);
  out->set_watchdog_trips(sample.render.watchdog_trips);
  out->set_passivity_activations(sample.render.passivity_activations);
  out->set_tick_overruns(sample.render.tick_overruns);
  out->set_tick_us_max(sample.tick_us_max);
  if (sample.model_version != 0 || sample.model_fragments_sent != 0) {
    out->set_model_version(sample.model_version);
    WriteVector(sample.device_avatar_W, out->mutable_device_avatar());
    out->set_model_fragments_sent(sample.model_fragments_sent);
  }
  out->set_server_energy_in(sample.server_energy.in);
  out->set_server_energy_out(sample.server_energy.out);
  out->set_device_energy_in(sample.device_energy.in);
  out->set_device_energy_out(sample.device_energy.out);
  out->set_channel_energy((sample.device_energy.out - sample.device_energy.in) +
                          (sample.server_energy.out - sample.server_energy.in));
  out->set_drift(sample.drift_m);
  out->set_max_drift(sample.max_drift_m);
  out->set_tdpa_activations(sample.tdpa_activations);
  out->set_states_held(sample.states_held);
  out->set_keepalives(sample.keepalives);
  out->set_commands_held(sample.commands_held);
  out->set_predicted_ticks(sample.predicted_ticks);
}

void ControlService::WriteCounters(v1::ServerCounters* out) const {
  out->set_datagrams_received(realtime_.datagrams_received.load());
  out->set_commands_sent(realtime_.commands_sent.load());
  out->set_malformed(realtime_.malformed.load());
  out->set_oversized(realtime_.oversized.load());
  out->set_unknown_session(realtime_.unknown_session.load());
  out->set_bad_mac(realtime_.bad_tag.load());
  out->set_replayed(realtime_.replayed.load());
  out->set_reordered(realtime_.reordered.load());
  out->set_send_errors(realtime_.send_errors.load());
  out->set_sessions_opened(sessions_opened_);
  out->set_sessions_closed(sessions_closed_);
  out->set_sessions_timed_out(realtime_.sessions_timed_out.load());
  out->set_control_errors(control_errors_);
  out->set_connections_open(connection_counters_.open);
  out->set_connections_refused(connection_counters_.refused);
  out->set_connections_timed_out(connection_counters_.timed_out);
  out->set_hello_failures(connection_counters_.hello_failures);
  out->set_ended_session(realtime_.ended_session.load());
}

}  // namespace hapticd::net
