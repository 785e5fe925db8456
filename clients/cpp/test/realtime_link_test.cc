#include "clients/cpp/realtime_link.h"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "clients/cpp/tick_schedule.h"
#include "hapticd/v1/hapticd.pb.h"
#include "server/net/test/count_allocations.h"

namespace hapticd::proxy {
namespace {

using net::Vector3;

net::SessionKey TestKey(uint8_t seed) {
  net::SessionKey key;
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(seed + 3 * i);
  return key;
}

constexpr uint32_t kSession = 0x1234abcd;

// A stand-in for hapticd's UDP side on a loopback port: it reads the link's states and
// answers whatever the test tells it to.
class FakeServer {
 public:
  FakeServer() {
    fd_ = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address);
    socklen_t size = sizeof address;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &size);
    endpoint_ = asio::ip::udp::endpoint(asio::ip::address_v4::loopback(), ntohs(address.sin_port));
  }
  ~FakeServer() { close(fd_); }

  const asio::ip::udp::endpoint& endpoint() const { return endpoint_; }

  // The next state within 1 s (its tag checked under key), remembering who sent it.
  std::optional<net::DeviceStateSample> ReceiveState(const net::SessionKey& key) {
    pollfd waiter{fd_, POLLIN, 0};
    if (poll(&waiter, 1, 1000) <= 0) return std::nullopt;
    socklen_t size = sizeof peer_;
    const ssize_t n = recvfrom(fd_, buffer_.data(), buffer_.size(), 0, reinterpret_cast<sockaddr*>(&peer_), &size);
    if (n <= 0) return std::nullopt;
    const std::span<const uint8_t> datagram(buffer_.data(), static_cast<std::size_t>(n));
    net::DeviceStateSample state;
    if (!net::CheckTag(datagram, key) || net::ParseState(datagram, state) != net::DatagramError::kNone) {
      return std::nullopt;
    }
    return state;
  }

  void SendRaw(std::span<const uint8_t> bytes) {
    sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&peer_), sizeof peer_);
  }

  // A command for sequence, sealed under key, carrying fragment when given.
  void SendCommand(uint64_t sequence, const net::SessionKey& key, uint32_t session = kSession, double fx = 1.5,
                   const net::ModelFragmentView& fragment = {}) {
    net::DeviceCommandSample command;
    command.model = fragment;
    command.session_id = session;
    command.sequence = sequence;
    command.f_W = Vector3(fx, 0, 0);
    command.contact = true;
    std::array<uint8_t, net::kMaxDatagramSize> out;
    const std::size_t size = net::EncodeCommand(command, key, out);
    SendRaw({out.data(), size});
  }

 private:
  int fd_;
  asio::ip::udp::endpoint endpoint_;
  sockaddr_in peer_{};
  std::array<uint8_t, 2048> buffer_;
};

// Waits (up to 1 s) for link to take an answer or count a drop.
bool AwaitOne(LinkSet& set) { return set.AwaitAll(MonotonicNowNs() + 1'000'000'000) == 1; }

// Drains until the counters move (a dropped datagram answers nothing to wait for).
void DrainUntilCounted(RealtimeLink& link, uint64_t LinkCounters::*counter, uint64_t expected) {
  const int64_t give_up = MonotonicNowNs() + 1'000'000'000;
  while (link.counters().*counter < expected && MonotonicNowNs() < give_up) link.Drain();
}

struct LinkFixture : ::testing::Test {
  LinkFixture() : key(TestKey(9)), link(kSession, key, server.endpoint()), links{&link}, set(links) {}

  uint64_t SendState() {
    net::DeviceStateSample state;
    state.p_WD = Vector3(0.1, 0.2, 0.3);
    EXPECT_TRUE(link.Send(state));
    const auto received = server.ReceiveState(key);
    EXPECT_TRUE(received.has_value());
    EXPECT_EQ(received->session_id, kSession);
    EXPECT_EQ(received->sequence, state.sequence);
    EXPECT_EQ(received->p_WD, Vector3(0.1, 0.2, 0.3));
    return state.sequence;
  }

  FakeServer server;
  net::SessionKey key;
  RealtimeLink link;
  std::array<RealtimeLink*, 1> links;
  LinkSet set;
};

TEST_F(LinkFixture, TakesTheMatchingCommandAndTimesIt) {
  const uint64_t sequence = SendState();
  EXPECT_EQ(sequence, 1u);
  server.SendCommand(sequence, key);
  ASSERT_TRUE(AwaitOne(set));
  EXPECT_TRUE(link.answered());
  EXPECT_EQ(link.command().f_W, Vector3(1.5, 0, 0));
  EXPECT_TRUE(link.command().contact);
  EXPECT_GT(link.rtt_ns(), 0);
  EXPECT_GT(link.wire_rtt_ns(), 0);
  EXPECT_EQ(link.counters().sent, 1u);
  EXPECT_EQ(link.counters().answered, 1u);
  EXPECT_EQ(link.counters().lost(), 0u);
}

TEST_F(LinkFixture, DropsABadTag) {
  const uint64_t sequence = SendState();
  server.SendCommand(sequence, TestKey(10));
  DrainUntilCounted(link, &LinkCounters::bad, 1);
  EXPECT_EQ(link.counters().bad, 1u);
  EXPECT_FALSE(link.answered());
  // the genuine answer after it is still taken
  server.SendCommand(sequence, key);
  EXPECT_TRUE(AwaitOne(set));
}

TEST_F(LinkFixture, AnOlderStatesAnswerIsLateAndItsDuplicateStale) {
  const uint64_t first = SendState();
  const uint64_t second = SendState();
  ASSERT_EQ(second, first + 1);
  // the answer to the first state comes after the second was sent: late, once
  server.SendCommand(first, key);
  DrainUntilCounted(link, &LinkCounters::late, 1);
  server.SendCommand(first, key);
  server.SendCommand(0, key);
  DrainUntilCounted(link, &LinkCounters::stale, 2);
  EXPECT_EQ(link.counters().late, 1u);
  EXPECT_EQ(link.counters().stale, 2u);
  EXPECT_FALSE(link.answered());
  server.SendCommand(second, key);
  EXPECT_TRUE(AwaitOne(set));
  // a duplicate of the answer taken is stale too
  server.SendCommand(second, key);
  DrainUntilCounted(link, &LinkCounters::stale, 3);
  EXPECT_EQ(link.counters().stale, 3u);
  EXPECT_EQ(link.counters().answered, 1u);
  EXPECT_EQ(link.counters().lost(), 0u);
}

// Answers older than the window cannot be placed: stale, and their state stays lost.
TEST_F(LinkFixture, AnAnswerOlderThanTheWindowIsStale) {
  const uint64_t first = SendState();
  for (int i = 0; i < RealtimeLink::kWindow; ++i) SendState();
  server.SendCommand(first, key);
  DrainUntilCounted(link, &LinkCounters::stale, 1);
  EXPECT_EQ(link.counters().stale, 1u);
  EXPECT_EQ(link.counters().late, 0u);
  EXPECT_EQ(link.counters().lost(), static_cast<uint64_t>(RealtimeLink::kWindow) + 1);
}

TEST_F(LinkFixture, DropsOtherSessionsFutureSequencesAndJunk) {
  const uint64_t sequence = SendState();
  // well tagged, but for another session, or for a state never sent
  server.SendCommand(sequence, key, kSession + 1);
  server.SendCommand(sequence + 1, key);
  // shorter than a tag, and longer than a datagram may be
  const std::array<uint8_t, 5> tiny{1, 2, 3, 4, 5};
  server.SendRaw(tiny);
  std::array<uint8_t, net::kMaxDatagramSize + 1> huge{};
  server.SendRaw(huge);
  DrainUntilCounted(link, &LinkCounters::bad, 4);
  EXPECT_EQ(link.counters().bad, 4u);
  EXPECT_FALSE(link.answered());
}

TEST_F(LinkFixture, AnAnswerAfterItsWaitIsLate) {
  LatencyStats wire(4);
  link.set_wire_rtt_sink(&wire);
  const uint64_t sequence = SendState();
  link.Expire();
  server.SendCommand(sequence, key);
  DrainUntilCounted(link, &LinkCounters::late, 1);
  EXPECT_EQ(link.counters().late, 1u);
  EXPECT_FALSE(link.answered());
  EXPECT_EQ(link.counters().lost(), 0u);
  // its wire round trip is still recorded
  ASSERT_EQ(wire.count(), 1u);
  EXPECT_GT(wire.samples()[0], 0);
}

// Across a delay every command is late: the newest one that came is kept for the loop to
// render, an older one arriving after it is not.
TEST_F(LinkFixture, TheNewestCommandIsKeptInTimeOrLate) {
  EXPECT_FALSE(link.fresh());
  const uint64_t first = SendState();
  const uint64_t second = SendState();
  link.Expire();
  server.SendCommand(second, key, kSession, 2.0);
  DrainUntilCounted(link, &LinkCounters::late, 1);
  ASSERT_TRUE(link.fresh());
  EXPECT_EQ(link.newest().sequence, second);
  EXPECT_EQ(link.newest().f_W, Vector3(2.0, 0, 0));
  link.ClearFresh();
  server.SendCommand(first, key, kSession, 1.0);
  DrainUntilCounted(link, &LinkCounters::late, 2);
  EXPECT_FALSE(link.fresh());
  EXPECT_EQ(link.newest().sequence, second);
  // the next state's answer in time is the newest too
  const uint64_t third = SendState();
  server.SendCommand(third, key, kSession, 3.0);
  ASSERT_TRUE(AwaitOne(set));
  EXPECT_TRUE(link.fresh());
  EXPECT_EQ(link.newest().f_W, Vector3(3.0, 0, 0));
}

// What a sink was offered.
struct RecordingSink final : FragmentSink {
  void Offer(const net::ModelFragmentView& fragment) override {
    offered.push_back({fragment.version, fragment.index, fragment.count,
                       std::string(fragment.data.begin(), fragment.data.end())});
  }
  struct Seen {
    uint64_t version;
    uint32_t index;
    uint32_t count;
    std::string data;
  };
  std::vector<Seen> offered;
};

// Model fragments reach the sink from every authentic command of the session (a
// duplicate's or a watchdog command's too), never from a forged one.
TEST_F(LinkFixture, ModelFragmentsGoToTheSink) {
  RecordingSink sink;
  link.set_fragment_sink(&sink);
  const std::array<uint8_t, 4> data{'a', 'b', 'c', 'd'};
  const uint64_t sequence = SendState();
  server.SendCommand(sequence, key, kSession, 1.5, {7, 1, 3, data});
  ASSERT_TRUE(AwaitOne(set));
  server.SendCommand(sequence, key, kSession, 1.5, {7, 2, 3, data});  // a duplicate: stale
  server.SendCommand(0, key, kSession, 1.5, {7, 0, 3, data});         // the server's watchdog
  DrainUntilCounted(link, &LinkCounters::stale, 2);
  server.SendCommand(sequence, TestKey(10), kSession, 1.5, {8, 0, 1, data});  // forged
  server.SendCommand(sequence, key, kSession + 1, 1.5, {9, 0, 1, data});      // another session's
  DrainUntilCounted(link, &LinkCounters::bad, 2);
  ASSERT_EQ(sink.offered.size(), 3u);
  EXPECT_EQ(sink.offered[0].index, 1u);
  EXPECT_EQ(sink.offered[1].index, 2u);
  EXPECT_EQ(sink.offered[2].index, 0u);
  for (const RecordingSink::Seen& seen : sink.offered) {
    EXPECT_EQ(seen.version, 7u);
    EXPECT_EQ(seen.count, 3u);
    EXPECT_EQ(seen.data, "abcd");
  }
  // the command kept for the loop carries no view into the receive buffer
  EXPECT_EQ(link.command().model.count, 0u);
  EXPECT_EQ(link.newest().model.count, 0u);
}

// Nothing comes: the wait ends at its deadline with nothing answered.
TEST_F(LinkFixture, AwaitEndsAtTheDeadline) {
  SendState();
  const int64_t deadline = MonotonicNowNs() + 3'000'000;
  EXPECT_EQ(set.AwaitAll(deadline), 0);
  EXPECT_GE(MonotonicNowNs(), deadline);
  link.Expire();
  EXPECT_EQ(link.counters().lost(), 1u);
}

// Send, answer, drain: after the first tick, no heap allocation on the link's side.
TEST_F(LinkFixture, ATickAllocatesNothing) {
  server.SendCommand(SendState(), key);
  ASSERT_TRUE(AwaitOne(set));
  for (int tick = 0; tick < 20; ++tick) {
    net::DeviceStateSample state;
    const long before = hapticd::testing::AllocationCount();
    ASSERT_TRUE(link.Send(state));
    const long after_send = hapticd::testing::AllocationCount();
    EXPECT_EQ(after_send, before);
    server.ReceiveState(key);
    server.SendCommand(state.sequence, key);
    const long before_wait = hapticd::testing::AllocationCount();
    ASSERT_EQ(set.AwaitAll(MonotonicNowNs() + 1'000'000'000), 1);
    EXPECT_EQ(hapticd::testing::AllocationCount(), before_wait);
  }
}

// Against an echo the answer is the state itself, read back as a command without force.
TEST(RealtimeLink, EchoModeTakesTheStateBack) {
  FakeServer echo;
  const net::SessionKey key = TestKey(4);
  RealtimeLink link(7, key, echo.endpoint(), LinkPeer::kEcho);
  std::array<RealtimeLink*, 1> links{&link};
  LinkSet set(links);
  net::DeviceStateSample state;
  state.p_WD = Vector3(0.5, 0, 0);
  ASSERT_TRUE(link.Send(state));
  ASSERT_TRUE(echo.ReceiveState(key).has_value());
  std::array<uint8_t, net::kMaxDatagramSize> bytes;
  const std::size_t size = net::EncodeState(state, key, bytes);
  echo.SendRaw({bytes.data(), size});
  ASSERT_TRUE(AwaitOne(set));
  EXPECT_EQ(link.command().sequence, 1u);
  EXPECT_EQ(link.command().f_W, Vector3::Zero());
  EXPECT_EQ(link.command().p_command_W, Vector3(0.5, 0, 0));
  // a command is not what an echo sends back: malformed as a state, or a bad tag
  echo.SendCommand(1, TestKey(5), 7);
  DrainUntilCounted(link, &LinkCounters::bad, 1);
  EXPECT_EQ(link.counters().bad, 1u);
}

// Several links: the wait returns once every one is answered.
TEST(LinkSet, AwaitsEveryLink) {
  FakeServer server;
  const net::SessionKey key = TestKey(1);
  RealtimeLink a(kSession, key, server.endpoint());
  RealtimeLink b(kSession, key, server.endpoint());
  std::array<RealtimeLink*, 2> links{&a, &b};
  LinkSet set(links);
  net::DeviceStateSample state;
  ASSERT_TRUE(a.Send(state));
  ASSERT_TRUE(server.ReceiveState(key).has_value());
  server.SendCommand(1, key);
  ASSERT_TRUE(b.Send(state));
  ASSERT_TRUE(server.ReceiveState(key).has_value());
  server.SendCommand(1, key);
  EXPECT_EQ(set.AwaitAll(MonotonicNowNs() + 1'000'000'000), 2);
  EXPECT_TRUE(a.answered());
  EXPECT_TRUE(b.answered());
}

// An authentic command saying the session ended is remembered (the proxy loop stops on
// it); a forged one is not.
TEST(RealtimeLink, RemembersThatTheServerEndedTheSession) {
  FakeServer server;
  const net::SessionKey key = TestKey(5);
  RealtimeLink link(kSession, key, server.endpoint());
  net::DeviceStateSample state;
  ASSERT_TRUE(link.Send(state));
  ASSERT_TRUE(server.ReceiveState(key));
  auto send_flagged = [&](const net::SessionKey& with, uint32_t flags) {
    net::DeviceCommandSample command;
    command.session_id = kSession;
    command.sequence = 1;
    command.flags = flags;
    std::array<uint8_t, net::kMaxDatagramSize> out;
    server.SendRaw({out.data(), net::EncodeCommand(command, with, out)});
  };
  send_flagged(TestKey(9), hapticd::v1::COMMAND_FLAGS_SESSION_CLOSED);  // forged
  send_flagged(key, hapticd::v1::COMMAND_FLAGS_NONE);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!link.Drain()) ASSERT_LT(std::chrono::steady_clock::now(), deadline);
  EXPECT_EQ(link.ended_flags(), 0u);
  ASSERT_TRUE(link.Send(state));
  ASSERT_TRUE(server.ReceiveState(key));
  net::DeviceCommandSample command;
  command.session_id = kSession;
  command.sequence = 2;
  command.flags = hapticd::v1::COMMAND_FLAGS_SESSION_TIMED_OUT;
  std::array<uint8_t, net::kMaxDatagramSize> out;
  server.SendRaw({out.data(), net::EncodeCommand(command, key, out)});
  while (!link.Drain()) ASSERT_LT(std::chrono::steady_clock::now(), deadline);
  EXPECT_EQ(link.ended_flags(), static_cast<uint32_t>(hapticd::v1::COMMAND_FLAGS_SESSION_TIMED_OUT));
}

}  // namespace
}  // namespace hapticd::proxy
