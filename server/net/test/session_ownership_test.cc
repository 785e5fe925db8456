// Who may do what: roles by token, sessions owned by the connection that opened them,
// ended sessions answered as such on the realtime channel, bounded listings.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <fmt/format.h>

#include "server/net/control_service.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using testing::DeviceSocket;
using testing::Harness;

void ExpectError(const v1::Reply& reply, v1::Error::Code code, const std::string& message) {
  ASSERT_TRUE(reply.has_error()) << reply.DebugString();
  EXPECT_EQ(reply.error().code(), code) << reply.error().message();
  EXPECT_EQ(reply.error().message(), message);
}

v1::Request OpenRequest() {
  v1::Request request;
  v1::OpenSession* open = request.mutable_open_session();
  open->set_device_type(v1::DEVICE_TYPE_IMPEDANCE);
  open->set_degrees_of_freedom(3);
  open->set_max_force(10);
  open->set_max_velocity(1);
  open->set_rate_hz(1000);
  open->mutable_start()->set_z(0.2);
  return request;
}

v1::Request CloseRequest(uint32_t id, const std::string& key = "") {
  v1::Request request;
  request.mutable_close_session()->set_session_id(id);
  request.mutable_close_session()->set_session_key(key);
  return request;
}

// Polls until the realtime thread handed the slot back and the service reclaimed it.
void AwaitReclaimed(Harness& harness, uint32_t id) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (harness.sessions.FindById(id) >= 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "session " << id << " was never reclaimed";
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    harness.service.ReclaimSessions();
  }
}

// A session belongs to the connection that opened it: another connection closes it
// only with its key. (Any client could close any session, their ids listed in stats.)
TEST(SessionOwnership, OnlyTheOwnerOrTheKeyHolderCloses) {
  Harness harness;
  const v1::SessionOpened opened = harness.Call(OpenRequest()).session_opened();
  ConnectionState other;
  other.authenticated = true;
  other.id = 2;
  ExpectError(harness.service.Handle(CloseRequest(opened.session_id()), other), v1::Error::CODE_PERMISSION_DENIED,
              fmt::format("close_session.session_id is {:08x}; another connection opened it, so closing it here "
                          "needs its session_key",
                          opened.session_id()));
  ExpectError(harness.service.Handle(CloseRequest(opened.session_id(), std::string(32, 'x')), other),
              v1::Error::CODE_PERMISSION_DENIED,
              fmt::format("close_session.session_id is {:08x}; another connection opened it, so closing it here "
                          "needs its session_key",
                          opened.session_id()));
  // with the key, from anywhere
  EXPECT_TRUE(harness.service.Handle(CloseRequest(opened.session_id(), opened.session_key()), other).has_done());

  // the owner needs no key; once its connection is gone, only the key closes the session
  const v1::SessionOpened mine = harness.Call(OpenRequest()).session_opened();
  const v1::SessionOpened orphan = harness.Call(OpenRequest()).session_opened();
  EXPECT_TRUE(harness.Call(CloseRequest(mine.session_id())).has_done());
  harness.service.ConnectionClosed(harness.connection.id);
  EXPECT_TRUE(harness.Call(CloseRequest(orphan.session_id())).has_error());
  EXPECT_TRUE(harness.Call(CloseRequest(orphan.session_id(), orphan.session_key())).has_done());
}

// An observer token reads; everything that changes the scene or the sessions needs the
// operator's.
TEST(SessionOwnership, AnObserverOnlyReads) {
  Harness harness;
  ServiceOptions options = harness.Options();
  options.observer_token = "observer-token-0123456789";
  ControlService service(testing::MakeTestScene(), harness.publisher, harness.sessions, harness.realtime.counters(),
                         options);
  ConnectionState observer;
  observer.id = 5;
  v1::Request hello;
  hello.mutable_hello()->set_protocol_version(1);
  hello.mutable_hello()->set_access_token("observer-token-0123456789");
  const v1::Reply welcome = service.Handle(hello, observer);
  ASSERT_TRUE(welcome.has_hello()) << welcome.DebugString();
  EXPECT_EQ(welcome.hello().role(), "observer");
  v1::Request get;
  get.mutable_get_scene();
  EXPECT_TRUE(service.Handle(get, observer).has_scene());
  v1::Request stats;
  stats.mutable_get_stats();
  EXPECT_TRUE(service.Handle(stats, observer).has_stats());
  v1::Request clear;
  clear.mutable_clear_scene();
  ExpectError(service.Handle(clear, observer), v1::Error::CODE_PERMISSION_DENIED,
              "clear_scene needs the operator's token; this connection's role is observer");
  ExpectError(service.Handle(OpenRequest(), observer), v1::Error::CODE_PERMISSION_DENIED,
              "open_session needs the operator's token; this connection's role is observer");
  EXPECT_EQ(harness.publisher.current()->num_objects(), 2);
  // the operator's token makes an operator
  ConnectionState operator_connection;
  hello.mutable_hello()->set_access_token(harness.Options().access_token);
  EXPECT_EQ(service.Handle(hello, operator_connection).hello().role(), "operator");
  EXPECT_TRUE(service.Handle(clear, operator_connection).has_done());
}

// A subscription to a session that does not exist would watch nothing for ever.
TEST(SessionOwnership, SubscribingToAnUnknownSessionIsRefused) {
  Harness harness;
  const v1::SessionOpened opened = harness.Call(OpenRequest()).session_opened();
  v1::Request subscribe;
  subscribe.set_request_id(3);
  subscribe.mutable_subscribe()->set_rate_hz(10);
  subscribe.mutable_subscribe()->add_session_ids(opened.session_id());
  subscribe.mutable_subscribe()->add_session_ids(0x1234);
  ExpectError(harness.Call(subscribe), v1::Error::CODE_NOT_FOUND,
              "subscribe.session_ids[1] is 00001234; no session has that id");
  subscribe.mutable_subscribe()->mutable_session_ids()->RemoveLast();
  EXPECT_TRUE(harness.Call(subscribe).has_telemetry());
}

// Churn cannot grow a listing: at most 64 ended sessions are listed, the latest.
TEST(SessionOwnership, EndedSessionsListedAreBounded) {
  Harness harness(4);
  harness.realtime.Start();
  uint32_t last = 0;
  for (int i = 0; i < 100; ++i) {
    last = harness.Call(OpenRequest()).session_opened().session_id();
    ASSERT_NE(last, 0u) << i;
    ASSERT_TRUE(harness.Call(CloseRequest(last)).has_done());
    AwaitReclaimed(harness, last);
  }
  v1::Request stats;
  stats.mutable_get_stats();
  const v1::Stats listed = harness.Call(stats).stats();
  EXPECT_EQ(listed.sessions_size(), 64);
  EXPECT_EQ(listed.sessions(63).session_id(), last);
  EXPECT_EQ(listed.counters().sessions_closed(), 100u);
}

// A device whose session ended gets told so, in a command tagged with its old key,
// instead of silence it could not tell from packet loss.
TEST(SessionOwnership, AnEndedSessionsStatesAreAnsweredAsEnded) {
  Harness harness;
  harness.realtime.Start();
  const v1::SessionOpened opened = harness.Call(OpenRequest()).session_opened();
  SessionKey key{};
  std::copy(opened.session_key().begin(), opened.session_key().end(), key.begin());
  DeviceSocket device(harness.realtime.local_endpoint().port());
  auto exchange = [&](uint64_t sequence) -> std::optional<DeviceCommandSample> {
    DeviceStateSample state;
    state.session_id = opened.session_id();
    state.sequence = sequence;
    state.send_time_ns = 1'000'000 * sequence;
    state.p_WD = {0, 0, 0.2};
    std::array<uint8_t, kMaxDatagramSize> buffer;
    device.SendRaw({buffer.data(), EncodeState(state, key, buffer)});
    const auto bytes = device.Receive(500);
    if (!bytes) return std::nullopt;
    EXPECT_TRUE(CheckTag(*bytes, key));
    DeviceCommandSample command;
    EXPECT_EQ(ParseCommand(*bytes, command), DatagramError::kNone);
    return command;
  };
  const auto live = exchange(1);
  ASSERT_TRUE(live);
  EXPECT_EQ(live->flags, 0u);
  ASSERT_TRUE(harness.Call(CloseRequest(opened.session_id())).has_done());
  AwaitReclaimed(harness, opened.session_id());
  const auto ended = exchange(2);
  ASSERT_TRUE(ended);
  EXPECT_EQ(ended->flags, static_cast<uint32_t>(v1::COMMAND_FLAGS_SESSION_CLOSED));
  EXPECT_EQ(ended->sequence, 2u);
  EXPECT_EQ(ended->f_W, Vector3::Zero());
  EXPECT_EQ(harness.realtime.counters().ended_session.load(), 1u);
  // the same state again (a replay) is not reflected back; a newer one is answered
  EXPECT_FALSE(exchange(2));
  EXPECT_FALSE(exchange(1));
  ASSERT_TRUE(exchange(3));
  EXPECT_EQ(harness.realtime.counters().ended_session.load(), 2u);
  // a forged state for the ended session is not answered
  DeviceStateSample forged;
  forged.session_id = opened.session_id();
  forged.sequence = 4;
  std::array<uint8_t, kMaxDatagramSize> buffer;
  SessionKey wrong{};
  device.SendRaw({buffer.data(), EncodeState(forged, wrong, buffer)});
  EXPECT_FALSE(device.Receive(200));
  EXPECT_EQ(harness.realtime.counters().unknown_session.load(), 3u);
}

}  // namespace
}  // namespace hapticd::net
