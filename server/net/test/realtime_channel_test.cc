// The realtime channel over a real loopback UDP socket: what a device gets back, and
// what the channel drops and counts.
#include "server/net/realtime_channel.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <thread>

#include <gtest/gtest.h>

#include "server/net/test/count_allocations.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using testing::DeviceSocket;
using testing::Harness;

// How long a test waits for the realtime thread to do something (answer, count, hand a
// slot back) before it fails: far beyond what a loaded machine needs; a test that
// passes goes on as soon as it has happened.
constexpr int kDeadlineMs = 5000;
// How long a state that must be dropped has to stay unanswered.
constexpr int kQuietMs = 200;

// Polls condition every millisecond until it holds (true) or kDeadlineMs pass (false).
// Allocates nothing.
template <typename Condition>
bool WaitUntil(Condition condition) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kDeadlineMs);
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

// Waits until counter reaches expected, then checks that it is exactly that.
void ExpectCountReaches(const std::atomic<uint64_t>& counter, uint64_t expected, const char* name) {
  EXPECT_TRUE(WaitUntil([&] { return counter.load() >= expected; }))
      << name << " did not reach " << expected << " within " << kDeadlineMs << " ms";
  EXPECT_EQ(counter.load(), expected) << name;
}

struct OpenedSession {
  uint32_t id = 0;
  SessionKey key{};
};

OpenedSession Open(Harness& harness, v1::DeviceType type, const Vector3& start, double timeout_s = 0,
                   const std::function<void(v1::OpenSession&)>& more = {}) {
  v1::Request request;
  v1::OpenSession* open = request.mutable_open_session();
  open->set_device_type(type);
  open->set_degrees_of_freedom(3);
  open->set_max_force(50);
  open->set_max_velocity(20);
  open->set_rate_hz(1000);
  open->set_timeout_s(timeout_s);
  open->mutable_start()->set_x(start.x());
  open->mutable_start()->set_y(start.y());
  open->mutable_start()->set_z(start.z());
  if (more) more(*open);
  const v1::Reply reply = harness.Call(request);
  EXPECT_TRUE(reply.has_session_opened()) << reply.DebugString();
  OpenedSession session;
  session.id = reply.session_opened().session_id();
  std::copy(reply.session_opened().session_key().begin(), reply.session_opened().session_key().end(),
            session.key.begin());
  return session;
}

class RealtimeChannelTest : public ::testing::Test {
 protected:
  void SetUp() override { harness_.realtime.Start(); }

  // Sends one state and returns the command that answers it (nullopt: no datagram came
  // within timeout_ms; a state that must be dropped waits only kQuietMs).
  std::optional<DeviceCommandSample> Exchange(DeviceSocket& device, const OpenedSession& session,
                                              DeviceStateSample state,
                                              int timeout_ms = kDeadlineMs) {
    state.session_id = session.id;
    std::array<uint8_t, kMaxDatagramSize> buffer;
    const std::size_t size = EncodeState(state, session.key, buffer);
    device.SendRaw({buffer.data(), size});
    // The answer, past any watchdog command sent while the device was quiet.
    for (;;) {
      const auto bytes = device.Receive(timeout_ms);
      if (!bytes) return std::nullopt;
      DeviceCommandSample command;
      EXPECT_EQ(ParseCommand(*bytes, command), DatagramError::kNone);
      if (command.flags & v1::COMMAND_FLAGS_WATCHDOG) continue;
      EXPECT_TRUE(CheckTag(*bytes, session.key));
      return command;
    }
  }

  std::optional<DeviceCommandSample> ReceiveCommand(DeviceSocket& device, const OpenedSession& session,
                                                    int timeout_ms) {
    const auto bytes = device.Receive(timeout_ms);
    if (!bytes) return std::nullopt;
    EXPECT_TRUE(CheckTag(*bytes, session.key));
    DeviceCommandSample command;
    EXPECT_EQ(ParseCommand(*bytes, command), DatagramError::kNone);
    return command;
  }

  DeviceStateSample StateAt(uint64_t sequence, const Vector3& p_WD) {
    DeviceStateSample state;
    state.sequence = sequence;
    state.send_time_ns = 1000 + sequence;
    state.p_WD = p_WD;
    return state;
  }

  Harness harness_;
};

TEST_F(RealtimeChannelTest, PressingIntoTheBoxFeelsStiffnessTimesDepth) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  uint64_t sequence = 0;
  for (double z : {0.08, 0.06, 0.051}) {
    const auto command = Exchange(device, session, StateAt(++sequence, {0, 0, z}));
    ASSERT_TRUE(command);
    EXPECT_FALSE(command->contact);
    EXPECT_EQ(command->f_W, Vector3::Zero());
  }
  // Down through the top face (z = 0.05) by d; F = k d along +z.
  for (double d : {0.001, 0.005, 0.01}) {
    const auto command = Exchange(device, session, StateAt(++sequence, {0, 0, 0.05 - d}));
    ASSERT_TRUE(command);
    EXPECT_EQ(command->session_id, session.id);
    EXPECT_EQ(command->sequence, sequence);
    EXPECT_EQ(command->echo_send_time_ns, 1000 + sequence);
    EXPECT_EQ(command->scene_version, 1u);
    EXPECT_TRUE(command->contact);
    EXPECT_NEAR(command->f_W.z(), 1000 * d, 1e-5);
    EXPECT_NEAR(command->f_W.head<2>().norm(), 0, 1e-9);
  }
  // Published before the command went out, so already visible.
  const SessionTelemetrySample telemetry =
      harness_.sessions.slot(harness_.sessions.FindById(session.id)).published.Read();
  EXPECT_EQ(telemetry.states_received, sequence);
  EXPECT_EQ(telemetry.commands_sent, sequence);
}

TEST_F(RealtimeChannelTest, DropsAndCountsWhatIsNotAFreshAuthenticState) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  const RealtimeCounters& counters = harness_.realtime.counters();
  ASSERT_TRUE(Exchange(device, session, StateAt(5, {0, 0, 0.1})));

  // Wrong key.
  OpenedSession forged = session;
  forged.key[0] ^= 1;
  EXPECT_FALSE(Exchange(device, forged, StateAt(6, {0, 0, 0.1}), kQuietMs));
  ExpectCountReaches(counters.bad_tag, 1, "bad_tag");
  // The same sequence again, and an older one never seen.
  EXPECT_FALSE(Exchange(device, session, StateAt(5, {0, 0, 0.1}), kQuietMs));
  ExpectCountReaches(counters.replayed, 1, "replayed");
  EXPECT_FALSE(Exchange(device, session, StateAt(4, {0, 0, 0.1}), kQuietMs));
  ExpectCountReaches(counters.reordered, 1, "reordered");
  // A session nobody opened.
  OpenedSession stranger = session;
  stranger.id = session.id + 1;
  EXPECT_FALSE(Exchange(device, stranger, StateAt(6, {0, 0, 0.1}), kQuietMs));
  ExpectCountReaches(counters.unknown_session, 1, "unknown_session");
  // Too long, too short, not protobuf.
  std::vector<uint8_t> big(kMaxDatagramSize + 100, 0x08);
  device.SendRaw(big);
  std::vector<uint8_t> tiny = {0x0d, 0x01};
  device.SendRaw(tiny);
  std::vector<uint8_t> garbage(64, 0xff);
  device.SendRaw(garbage);
  ExpectCountReaches(counters.oversized, 1, "oversized");
  ExpectCountReaches(counters.malformed, 2, "malformed");

  // Through all that, the session is served as before.
  const auto command = Exchange(device, session, StateAt(6, {0, 0, 0.04}));
  ASSERT_TRUE(command);
  EXPECT_NEAR(command->f_W.z(), 10, 1e-5);
  const SessionTelemetrySample telemetry = harness_.sessions.slot(harness_.sessions.FindById(session.id)).published.Read();
  EXPECT_EQ(telemetry.bad_tag, 1u);
  EXPECT_EQ(telemetry.replayed, 1u);
  EXPECT_EQ(telemetry.reordered, 1u);
  EXPECT_EQ(telemetry.states_received, 2u);
}

TEST_F(RealtimeChannelTest, NonFiniteStatesGetTheLastSafeForceAndAreCounted) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  ASSERT_TRUE(Exchange(device, session, StateAt(1, {0, 0, 0.06})));
  const auto pressed = Exchange(device, session, StateAt(2, {0, 0, 0.045}));
  ASSERT_TRUE(pressed);
  const auto bad = Exchange(device, session, StateAt(3, {NAN, 0, INFINITY}));
  ASSERT_TRUE(bad);
  EXPECT_TRUE(bad->f_W.allFinite());
  EXPECT_EQ(bad->f_W, pressed->f_W);
  EXPECT_EQ(harness_.sessions.slot(harness_.sessions.FindById(session.id)).published.Read().render.nonfinite_inputs, 1u);
}

TEST_F(RealtimeChannelTest, SilenceRampsTheForceToZeroThenTheSessionTimesOut) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}, 0.5);
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  ASSERT_TRUE(Exchange(device, session, StateAt(1, {0, 0, 0.06})));
  ASSERT_TRUE(Exchange(device, session, StateAt(2, {0, 0, 0.04})));

  // The device goes quiet: the watchdog's commands arrive, flagged, never growing, down to zero.
  double previous = 10 + 1e-5;
  int watchdog_commands = 0;
  while (const auto command = ReceiveCommand(device, session, kDeadlineMs)) {
    EXPECT_EQ(command->flags, static_cast<uint32_t>(v1::COMMAND_FLAGS_WATCHDOG));
    EXPECT_EQ(command->sequence, 0u);
    EXPECT_LE(command->f_W.norm(), previous + 1e-12);
    previous = command->f_W.norm();
    ++watchdog_commands;
    if (previous == 0) break;
  }
  EXPECT_GT(watchdog_commands, 10);
  EXPECT_EQ(previous, 0);
  const int index = harness_.sessions.FindById(session.id);
  EXPECT_EQ(harness_.sessions.slot(index).state.load(), SlotState::kRamping);

  // After the timeout (0.5 s of silence) the slot is handed back and reclaimed; the
  // session is gone.
  ASSERT_TRUE(WaitUntil([&] { return !IsLive(harness_.sessions.slot(index).state.load()); }))
      << "the silent session was not handed back within " << kDeadlineMs << " ms";
  EXPECT_EQ(harness_.sessions.slot(index).state.load(), SlotState::kTimedOut);
  harness_.service.ReclaimSessions();
  EXPECT_EQ(harness_.sessions.FindById(session.id), -1);
  EXPECT_EQ(harness_.realtime.counters().sessions_timed_out.load(), 1u);
  const v1::Telemetry telemetry = harness_.service.BuildTelemetry({});
  ASSERT_EQ(telemetry.sessions_size(), 1);
  EXPECT_EQ(telemetry.sessions(0).state(), v1::SESSION_STATE_TIMED_OUT);
  EXPECT_EQ(telemetry.sessions(0).force().z(), 0);
  // its device's next state is answered: the session timed out, zero force
  const auto ended = Exchange(device, session, StateAt(3, {0, 0, 0.04}));
  ASSERT_TRUE(ended);
  EXPECT_EQ(ended->flags, static_cast<uint32_t>(v1::COMMAND_FLAGS_SESSION_TIMED_OUT));
  EXPECT_EQ(ended->f_W, Vector3::Zero());
  EXPECT_EQ(harness_.realtime.counters().ended_session.load(), 1u);
  EXPECT_EQ(harness_.realtime.counters().unknown_session.load(), 0u);
}

TEST_F(RealtimeChannelTest, ClosedSessionsAreReclaimed) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  ASSERT_TRUE(Exchange(device, session, StateAt(1, {0, 0, 0.1})));
  const int index = harness_.sessions.FindById(session.id);
  ASSERT_GE(index, 0);
  v1::Request close;
  close.mutable_close_session()->set_session_id(session.id);
  EXPECT_TRUE(harness_.Call(close).has_done());
  // The realtime thread hands the closed slot back; then it is reclaimed.
  ASSERT_TRUE(WaitUntil([&] { return !IsLive(harness_.sessions.slot(index).state.load()); }))
      << "the closed session was not handed back within " << kDeadlineMs << " ms";
  harness_.service.ReclaimSessions();
  EXPECT_EQ(harness_.sessions.FindById(session.id), -1);
  const auto ended = Exchange(device, session, StateAt(2, {0, 0, 0.1}));
  ASSERT_TRUE(ended);
  EXPECT_EQ(ended->flags, static_cast<uint32_t>(v1::COMMAND_FLAGS_SESSION_CLOSED));
  // Closing it again names the id.
  const v1::Reply again = harness_.Call(close);
  ASSERT_TRUE(again.has_error());
  EXPECT_EQ(again.error().code(), v1::Error::CODE_NOT_FOUND);
}

// With no live session the realtime thread waits without a timeout: opening one rings
// the table's doorbell, so a session that never sends a state still times out, and
// Stop (at the end of every test) wakes the thread to end.
TEST_F(RealtimeChannelTest, ASessionOpenedWhileTheChannelIsIdleStillTimesOut) {
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // past the first pass: idle
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}, 0.2);
  const int index = harness_.sessions.FindById(session.id);
  ASSERT_GE(index, 0);
  ASSERT_TRUE(WaitUntil([&] { return !IsLive(harness_.sessions.slot(index).state.load()); }))
      << "the silent session was not handed back within " << kDeadlineMs << " ms";
  EXPECT_EQ(harness_.sessions.slot(index).state.load(), SlotState::kTimedOut);
  EXPECT_EQ(harness_.realtime.counters().sessions_timed_out.load(), 1u);
}

TEST_F(RealtimeChannelTest, AnAdmittanceAvatarPushedIntoTheBoxStopsOnItsSurface) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_ADMITTANCE, {0, 0, 0.07});
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  // 10 N down for 2 s of device ticks (sent as fast as answered).
  DeviceCommandSample last;
  for (uint64_t sequence = 1; sequence <= 2000; ++sequence) {
    DeviceStateSample state = StateAt(sequence, last.sequence ? last.p_command_W : Vector3(0, 0, 0.07));
    state.f_sensed_W = {0, 0, -10};
    const auto command = Exchange(device, session, state);
    ASSERT_TRUE(command) << sequence;
    ASSERT_GE(command->p_command_W.z(), 0.05 - 1e-9) << sequence;
    last = *command;
  }
  EXPECT_NEAR(last.p_command_W.z(), 0.05, 1e-6);
  EXPECT_TRUE(last.contact);
  EXPECT_EQ(last.f_W, Vector3::Zero());  // admittance commands carry a pose, not a force
}

// An admittance avatar integrates over the time between the device's states (its send
// stamps), bounded to [1/2, 2] periods: a stamp a second late moves it no further than
// two periods would. (It used to take the declared period whatever the real interval;
// and a rate of 1e-3 Hz, now refused, was a 1000 s step.)
TEST_F(RealtimeChannelTest, AdmittanceStepsFollowTheStampsWithinTwoPeriods) {
  const Vector3 start(0, 0, 0.5);  // far above the box: free motion
  // at 10 Hz: a state the test is slow to send (a loaded machine, ASan) is not met by a
  // silent tick (1.5 periods after the last, 150 ms), which would step the avatar too
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_ADMITTANCE, start, 0,
                                     [](v1::OpenSession& open) { open.set_rate_hz(10); });
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  // the free mass-damper step (virtual mass 1 kg, damping 20 N*s/m), pushed with 10 N
  double v = 0, x = 0;
  auto step = [&](double dt) {
    v = (1.0 * v + dt * 10) / (1.0 + dt * 20);
    x += dt * v;
  };
  const uint64_t t0 = 5'000'000'000;
  constexpr uint64_t kPeriodNs = 100'000'000;
  // first state: one period; ten periods late: two periods; then 0.7 and 1.5 periods as
  // sent; then one stamped 0.1 period later: half a period
  const std::vector<std::pair<uint64_t, double>> stamps = {
      {t0, 0.1}, {t0 + 10 * kPeriodNs, 0.2}, {t0 + 10 * kPeriodNs + 7 * kPeriodNs / 10, 0.07},
      {t0 + 12 * kPeriodNs + 2 * kPeriodNs / 10, 0.15}, {t0 + 12 * kPeriodNs + 3 * kPeriodNs / 10, 0.05}};
  uint64_t sequence = 0;
  for (const auto& [stamp, dt] : stamps) {
    DeviceStateSample state;
    state.sequence = ++sequence;
    state.send_time_ns = stamp;
    state.p_WD = start + Vector3(x, 0, 0);
    state.f_sensed_W = {10, 0, 0};
    const auto command = Exchange(device, session, state);
    ASSERT_TRUE(command);
    step(dt);
    EXPECT_NEAR(command->p_command_W.x(), x, 1e-12) << "state " << sequence;
    EXPECT_EQ(command->p_command_W.z(), start.z());
  }
}

TEST_F(RealtimeChannelTest, ManySessionsAreServedSideBySide) {
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  std::vector<OpenedSession> sessions;
  for (int i = 0; i < 8; ++i) sessions.push_back(Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}));
  // The table holds eight: a ninth is refused, naming why.
  v1::Request ninth;
  v1::OpenSession* open = ninth.mutable_open_session();
  open->set_device_type(v1::DEVICE_TYPE_IMPEDANCE);
  open->set_degrees_of_freedom(3);
  open->set_max_force(1);
  open->set_max_velocity(1);
  open->set_rate_hz(1000);
  const v1::Reply refused = harness_.Call(ninth);
  ASSERT_TRUE(refused.has_error());
  EXPECT_EQ(refused.error().code(), v1::Error::CODE_RESOURCE_EXHAUSTED);
  EXPECT_EQ(refused.error().message(), "all 8 session slots are in use");
  for (int round = 1; round <= 3; ++round) {
    for (int i = 0; i < 8; ++i) {
      const double depth = 0.001 * (i + 1);
      const auto command = Exchange(device, sessions[i], StateAt(round, {0, 0, 0.05 - depth}));
      ASSERT_TRUE(command);
      EXPECT_EQ(command->session_id, sessions[i].id);
      if (round > 1) {
        EXPECT_NEAR(command->f_W.z(), 1000 * depth, 1e-5);
      }
    }
  }
}

// Rendering a session's states, dropping bad ones and ramping a silent session: with
// the sessions open, nothing on either side of the socket allocates.
TEST_F(RealtimeChannelTest, TheRealtimePathAllocatesNothing) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  const OpenedSession second = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  // a third with two-port passivity and a deadband: its ports, held answers and
  // predicted ticks on the same path
  const OpenedSession channel = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}, 0, [](v1::OpenSession& open) {
    open.set_tdpa(true);
    open.set_deadband(0.1);
  });
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  ASSERT_TRUE(Exchange(device, session, StateAt(1, {0, 0, 0.06})));
  ASSERT_TRUE(Exchange(device, second, StateAt(1, {0, 0, 0.06})));
  ASSERT_TRUE(Exchange(device, channel, StateAt(1, {0, 0, 0.06})));
  const int first_index = harness_.sessions.FindById(session.id);
  const int second_index = harness_.sessions.FindById(second.id);
  ASSERT_GE(first_index, 0);
  ASSERT_GE(second_index, 0);

  // From here the test itself uses only preallocated buffers.
  std::array<uint8_t, kMaxDatagramSize> out;
  std::array<uint8_t, kMaxDatagramSize> forged;
  const long before = hapticd::testing::AllocationCount();
  int answered = 0;
  for (uint64_t sequence = 2; sequence < 500; ++sequence) {
    DeviceStateSample state = StateAt(sequence, {0.001 * (sequence % 7), 0, 0.05 - 1e-5 * sequence});
    state.v_WD = Vector3(0, 0, -0.01 * (sequence % 3));
    state.energy_in = 1e-4 * sequence;
    state.keepalive = sequence % 10 == 0;
    for (const OpenedSession* s : {&session, &second, &channel}) {
      state.session_id = s->id;
      const std::size_t size = EncodeState(state, s->key, out);
      device.SendRaw({out.data(), size});
      // A forged copy and a replay ride along, to be dropped.
      std::copy(out.begin(), out.begin() + size, forged.begin());
      forged[size - 1] ^= 1;
      device.SendRaw({forged.data(), size});
      device.SendRaw({out.data(), size});
    }
    pollfd waiter{device.fd(), POLLIN, 0};
    while (poll(&waiter, 1, 50) > 0 && recv(device.fd(), forged.data(), forged.size(), 0) > 0) {
      if (++answered % 2 == 0) break;
    }
  }
  // Then silence until both watchdogs have ramped to zero (published: ramping, no force).
  const auto ramped = [&](int index) {
    const SessionTelemetrySample telemetry = harness_.sessions.slot(index).published.Read();
    return telemetry.state == SlotState::kRamping && telemetry.f_W.isZero(0);
  };
  const bool both_ramped = WaitUntil([&] { return ramped(first_index) && ramped(second_index); });
  EXPECT_EQ(hapticd::testing::AllocationCount() - before, 0);
  EXPECT_TRUE(both_ramped) << "the watchdogs did not ramp both forces to zero within "
                           << kDeadlineMs << " ms";
  EXPECT_GE(answered, 900);
  EXPECT_GE(harness_.realtime.counters().bad_tag.load(), 900u);
  EXPECT_GE(harness_.realtime.counters().replayed.load(), 900u);
  const SessionTelemetrySample telemetry = harness_.sessions.slot(harness_.sessions.FindById(channel.id)).published.Read();
  EXPECT_GT(telemetry.tdpa_activations + telemetry.commands_held + telemetry.predicted_ticks, 0u);
}

// The channel's two ports: every impedance session reports them, and under TDPA the
// server lets its avatar input into the box only with energy the device let in: until
// then the input waits at the surface (the drift), then it catches up.
TEST_F(RealtimeChannelTest, TwoPortPassivityHoldsTheInputBackUntilEnergyComes) {
  const OpenedSession plain = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1});
  const OpenedSession tdpa =
      Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}, 0, [](v1::OpenSession& open) { open.set_tdpa(true); });
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  // both pressed 5 mm into the box (top z = 0.05, 1000 N/m), the device reporting no
  // energy let in
  std::optional<DeviceCommandSample> pressed, held;
  uint64_t number = 0;
  for (uint64_t sequence = 1; sequence <= 3; ++sequence) {
    const Vector3 p(0, 0, sequence == 1 ? 0.06 : 0.045);
    pressed = Exchange(device, plain, StateAt(sequence, p));
    held = Exchange(device, tdpa, StateAt(sequence, p));
    ASSERT_TRUE(pressed && held);
    // numbered from 1, in order (a watchdog command of a stalled test counts too)
    EXPECT_GT(held->command_number, number);
    if (sequence == 1) {
      EXPECT_EQ(held->command_number, 1u);
    }
    number = held->command_number;
  }
  EXPECT_NEAR(pressed->f_W.z(), 5, 1e-5);
  // the plain session's input went 5 mm in: its port let out work, which it reports
  EXPECT_GT(pressed->energy_out, 0);
  EXPECT_EQ(held->f_W, Vector3::Zero());
  EXPECT_EQ(held->energy_out, 0);
  const auto telemetry = [&] { return harness_.sessions.slot(harness_.sessions.FindById(tdpa.id)).published.Read(); };
  EXPECT_NEAR(telemetry().drift_m, 0.005, 1e-5);
  EXPECT_GT(telemetry().tdpa_activations, 0u);
  // the device reports 1 J let in: the input catches up and the box pushes back
  DeviceStateSample state = StateAt(4, {0, 0, 0.045});
  state.energy_in = 1;
  state.energy_out = 0.25;
  const auto caught = Exchange(device, tdpa, state);
  ASSERT_TRUE(caught);
  EXPECT_NEAR(caught->f_W.z(), 5, 1e-5);
  EXPECT_LE(caught->energy_out, 1);
  const SessionTelemetrySample after = telemetry();
  EXPECT_NEAR(after.drift_m, 0, 1e-12);
  EXPECT_NEAR(after.max_drift_m, 0.005, 1e-5);
  EXPECT_EQ(after.device_energy.in, 1);
  EXPECT_EQ(after.device_energy.out, 0.25);
  EXPECT_EQ(after.server_energy.out, caught->energy_out);
}

// A deadband session's answers: the first, a keep-alive's and any whose force leaves
// the band always go out; the rest may be held (counted), and a silent tick's
// prediction that leaves the band goes out flagged PREDICTED.
TEST_F(RealtimeChannelTest, TheDeadbandHoldsBackWhatAPersonCouldNotTell) {
  const OpenedSession session = Open(harness_, v1::DEVICE_TYPE_IMPEDANCE, {0, 0, 0.1}, 0, [](v1::OpenSession& open) {
    open.set_deadband(0.1);
    open.set_keepalive_s(0.025);
  });
  DeviceSocket device(harness_.realtime.local_endpoint().port());
  uint64_t sequence = 0;
  const auto first = Exchange(device, session, StateAt(++sequence, {0, 0, 0.045}));
  ASSERT_TRUE(first);
  EXPECT_NEAR(first->f_W.z(), 5, 1e-5);
  // within the band (5 N +- 0.5 N + 0.02 N): sent back to back, most are held
  std::array<uint8_t, kMaxDatagramSize> buffer;
  for (int i = 0; i < 100; ++i) {
    DeviceStateSample state = StateAt(++sequence, {0, 0, 0.045 - 1e-6 * (i % 5)});
    state.session_id = session.id;
    device.SendRaw({buffer.data(), EncodeState(state, session.key, buffer)});
  }
  const auto telemetry = [&] { return harness_.sessions.slot(harness_.sessions.FindById(session.id)).published.Read(); };
  EXPECT_TRUE(WaitUntil([&] { return telemetry().states_received == sequence; }));
  SessionTelemetrySample counted = telemetry();
  EXPECT_GE(counted.commands_held, 1u);
  EXPECT_LT(counted.commands_held, counted.states_received);  // the first was answered
  EXPECT_GE(counted.commands_held + counted.commands_sent, counted.states_received);
  while (device.Receive(0)) {
  }
  // out of the band: answered, carrying the count held so far
  const auto deeper = Exchange(device, session, StateAt(++sequence, {0, 0, 0.04}));
  ASSERT_TRUE(deeper);
  EXPECT_NEAR(deeper->f_W.z(), 10, 1e-5);
  EXPECT_EQ(deeper->commands_held, telemetry().commands_held);
  // a keep-alive in the band: answered
  DeviceStateSample keepalive = StateAt(++sequence, {0, 0, 0.04});
  keepalive.keepalive = true;
  keepalive.states_held = 57;
  const auto alive = Exchange(device, session, keepalive);
  ASSERT_TRUE(alive);
  EXPECT_EQ(alive->sequence, sequence);
  EXPECT_EQ(telemetry().states_held, 57u);
  EXPECT_EQ(telemetry().keepalives, 1u);
  // moving into the box at 1 m/s: the server's predictions leave the band before the
  // next state would come, and go out flagged, for this state (a machine stalled past
  // the keep-alive renders none: another state tries again)
  std::optional<DeviceCommandSample> predicted;
  for (int attempt = 0; attempt < 10 && !predicted; ++attempt) {
    DeviceStateSample moving = StateAt(++sequence, {0, 0, 0.04});
    moving.v_WD = Vector3(0, 0, -1);
    moving.keepalive = true;  // answered at once, so the prediction is measured from it
    ASSERT_TRUE(Exchange(device, session, moving));
    while (const auto next = ReceiveCommand(device, session, kQuietMs)) {
      if (next->flags & v1::COMMAND_FLAGS_PREDICTED) {
        predicted = next;
        break;
      }
    }
  }
  ASSERT_TRUE(predicted) << "no predicted command in 10 tries";
  EXPECT_EQ(predicted->sequence, sequence);
  EXPECT_GT(predicted->f_W.z(), 10.5);  // deeper than the state said
  EXPECT_GT(predicted->command_number, alive->command_number);
  EXPECT_GT(telemetry().predicted_ticks, 0u);
}

}  // namespace
}  // namespace hapticd::net
