#include "server/net/realtime_channel.h"

#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/socket.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <system_error>

#include <asio/io_context.hpp>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/model_codec.h"

namespace hapticd::net {
namespace {

// The housekeeping pass (silent sessions, closes, timeouts; see realtime_channel.h): at
// most one a millisecond by the clock, and while sessions live but have nothing due, one
// every kIdlePassNs (how soon a close is seen at the latest); with none live, none until
// a datagram comes or the session table's doorbell rings. One due within kEarlyPassNs
// runs right after a batch of datagrams, without a wake-up of its own (a device's next
// state, due 0.5 ms before its silent tick, may come a little early).
constexpr int64_t kTickNs = 1'000'000;
constexpr int64_t kIdlePassNs = 2'000'000;
constexpr int64_t kEarlyPassNs = kTickNs * 3 / 4;
constexpr int kSocketBufferBytes = 4 << 20;

double NsToSeconds(int64_t ns) { return static_cast<double>(ns) * 1e-9; }

// The step a fresh state integrates over: the time since the device's previous state,
// by its own send stamps (what it sampled), else by arrival; bounded to [1/2, 2] periods,
// so that a burst, a stall or a forged stamp moves an admittance avatar no further than
// the device could in two periods at its speed limit.
double StepSeconds(const SessionSlot& slot, int64_t send_ns, int64_t now_ns) {
  int64_t interval_ns = slot.period_ns;
  if (slot.last_send_ns > 0 && send_ns > slot.last_send_ns) {
    interval_ns = send_ns - slot.last_send_ns;
  } else if (slot.last_send_ns == 0 && slot.telemetry.states_received > 0) {
    interval_ns = now_ns - slot.last_state_ns;
  }
  return NsToSeconds(std::clamp(interval_ns, slot.period_ns / 2, 2 * slot.period_ns));
}

bool Impedance(const SessionSlot& slot) {
  return slot.render->settings().device.mode == force::DeviceMode::kImpedance;
}

// The avatar input's step towards target_W, the device's newest position (predicted on
// between a deadband's states), through the session's remote::RendererChannel: the
// whole way, or under TDPA as far as the server's port lets it (the rest is the drift).
// Admittance sessions move no input: the target goes to the session as it is.
Vector3 StepInput(SessionSlot& slot, const scene::SceneSnapshot& scene, const Vector3& target_W, double dt) {
  force::DeviceInput& input = slot.last_input;
  if (!Impedance(slot)) {
    input.p_WD = target_W;
    return Vector3::Zero();
  }
  const Vector3 step = slot.channel.StepInput(scene, target_W, slot.render->settings().avatar.radius, dt, input);
  // a non-finite target: the session counts and drops it, nothing stepped
  if (!target_W.allFinite()) return step;
  SessionTelemetrySample& telemetry = slot.telemetry;
  if (slot.channel.tdpa()) telemetry.tdpa_activations += slot.channel.end().port().active() ? 1 : 0;
  telemetry.drift_m = slot.channel.drift_m();
  telemetry.max_drift_m = std::max(telemetry.max_drift_m, telemetry.drift_m);
  return step;
}

// After the session's tick: the server's port observes what its input pushed into the
// scene over step (an input the session refused, counted in before's successors, moved
// nothing).
void ObserveTick(SessionSlot& slot, const force::TickOutput& output, const Vector3& step,
                 const force::SessionCounters& before) {
  if (!Impedance(slot)) return;
  const force::SessionCounters& after = slot.render->counters();
  const bool refused = after.nonfinite_inputs != before.nonfinite_inputs || after.absurd_inputs != before.absurd_inputs;
  slot.channel.ObserveTick(output, step, refused);
  slot.telemetry.server_energy = slot.channel.end().energy();
}

// What the session computed, as telemetry shows it (the command's force, where the device
// is, the avatar), whether or not a command goes out.
void RecordOutput(SessionSlot& slot, const force::TickOutput& output, uint64_t scene_version) {
  SessionTelemetrySample& telemetry = slot.telemetry;
  telemetry.f_W = Impedance(slot) ? output.f_W : Vector3::Zero();
  telemetry.p_WD = slot.channel.target_W();
  telemetry.avatar_W = output.avatar_W;
  telemetry.contact = output.contact;
  telemetry.touched_object = output.touched_object;
  telemetry.scene_version = scene_version;
}

// A local-model session's device does not hold the newest model yet: a command carries
// one of its fragments. For a prediction (a deadband's silent tick) only on the model's
// first pass through its fragments: after that they go with the answers to states, at
// the states' rate, rather than every tick while a model crosses a long round trip.
bool FragmentDue(SessionSlot& slot, bool predicted) {
  if (!slot.local_model) return false;
  const EncodedModel& model = slot.models->Newest();
  if (model.session_id != slot.id || model.version <= slot.telemetry.model_version) return false;
  const std::size_t count = std::max<std::size_t>(1, (model.size + kModelChunkSize - 1) / kModelChunkSize);
  return !predicted || model.version != slot.sending_version || slot.fragments_sent < count;
}

// Deadband sessions: whether this tick's output differs from what the device has by more
// than a person could tell: a fragment due (local model: the device renders its own
// force), else a force out of the last one's band.
bool OutOfBand(SessionSlot& slot, const force::TickOutput& output, bool predicted) {
  if (slot.local_model) return FragmentDue(slot, predicted);
  return slot.channel.ForceOutOfBand(output.f_W);
}

}  // namespace

int64_t MonotonicNowNs() {
  timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec;
}

struct RealtimeChannel::Batch {
  // One byte more than a datagram may have, so an oversized one is seen as such.
  std::array<std::array<uint8_t, kMaxStateSize + 1>, kBatch> in_data;
  std::array<iovec, kBatch> in_iov;
  std::array<sockaddr_storage, kBatch> in_peer;
  std::array<mmsghdr, kBatch> in_msgs;
  // Commands to send; at most one per received datagram plus one per silent session.
  std::vector<std::array<uint8_t, kMaxCommandSize>> out_data;
  std::vector<iovec> out_iov;
  std::vector<mmsghdr> out_msgs;
};

RealtimeChannel::RealtimeChannel(const asio::ip::udp::endpoint& endpoint, SessionTable& sessions,
                                 scene::SnapshotPublisher& publisher)
    : sessions_(sessions), publisher_(publisher), batch_(std::make_unique<Batch>()) {
  // The socket is opened and bound through asio (addresses, errors), then driven with
  // recvmmsg/sendmmsg on its descriptor.
  asio::io_context context;
  asio::ip::udp::socket socket(context);
  socket.open(endpoint.protocol());
  socket.bind(endpoint);
  local_endpoint_ = socket.local_endpoint();
  socket.non_blocking(true);
  socket.set_option(asio::socket_base::receive_buffer_size(kSocketBufferBytes));
  socket.set_option(asio::socket_base::send_buffer_size(kSocketBufferBytes));
  fd_ = socket.release();

  reader_ = publisher_.AddReader();
  if (reader_ < 0) throw std::runtime_error("no snapshot reader slot left for the realtime thread");

  // Preallocate every buffer the thread will use.
  Batch& b = *batch_;
  for (int i = 0; i < kBatch; ++i) {
    b.in_iov[i] = {b.in_data[i].data(), b.in_data[i].size()};
    b.in_msgs[i] = {};
    b.in_msgs[i].msg_hdr.msg_iov = &b.in_iov[i];
    b.in_msgs[i].msg_hdr.msg_iovlen = 1;
  }
  const int out_capacity = kBatch + sessions_.capacity();
  b.out_data.resize(out_capacity);
  b.out_iov.resize(out_capacity);
  b.out_msgs.resize(out_capacity);
}

RealtimeChannel::~RealtimeChannel() {
  Stop();
  publisher_.RemoveReader(reader_);
  ::close(fd_);
}

bool RealtimeChannel::Start(int priority) {
  if (thread_.joinable()) return true;
  stop_.store(false);
  thread_ = std::thread([this] { Run(); });
  // SCHED_FIFO keeps the tick ahead of scene building and everything else on the
  // machine; it needs CAP_SYS_NICE, and the channel works without it.
  if (priority <= 0) return false;
  sched_param parameters{};
  parameters.sched_priority = priority;
  return pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &parameters) == 0;
}

void RealtimeChannel::Stop() {
  stop_.store(true);
  sessions_.Ring();
  if (thread_.joinable()) thread_.join();
}

void RealtimeChannel::Run() {
  int64_t last_pass_ns = MonotonicNowNs();
  next_pass_ns_ = last_pass_ns + kTickNs;
  std::array<pollfd, 2> waiters{pollfd{fd_, POLLIN, 0}, pollfd{sessions_.doorbell_fd(), POLLIN, 0}};
  while (!stop_.load(std::memory_order_relaxed)) {
    // Wait for datagrams, at most until the pass is due (never sooner than a millisecond
    // after the last one, so that a stall is not replayed tick by tick); with no session
    // live, for a datagram or the doorbell (a session opened: its pass is due now).
    const int64_t due_ns = std::max(next_pass_ns_, last_pass_ns + kTickNs);
    const int64_t wait_ns = std::clamp<int64_t>(due_ns - MonotonicNowNs(), 0, kIdlePassNs);
    const timespec timeout{0, static_cast<long>(wait_ns)};
    for (pollfd& waiter : waiters) waiter.revents = 0;
    ppoll(waiters.data(), waiters.size(), any_live_ ? &timeout : nullptr, nullptr);
    if (waiters[1].revents & POLLIN) {
      sessions_.Answer();
      any_live_ = true;
      next_pass_ns_ = MonotonicNowNs();
    }
    const bool received = waiters[0].revents & POLLIN;
    if (received) ReceiveAndReply(MonotonicNowNs());

    // The pass, when due; while awake for datagrams, also when due soon.
    const int64_t now_ns = MonotonicNowNs();
    if (now_ns >= due_ns - (received ? kEarlyPassNs : 0)) {
      TickSilentSessions(now_ns);
      last_pass_ns = now_ns;
    }
  }
}

void RealtimeChannel::ReceiveAndReply(int64_t now_ns) {
  Batch& b = *batch_;
  for (int i = 0; i < kBatch; ++i) {
    b.in_msgs[i].msg_hdr.msg_name = &b.in_peer[i];
    b.in_msgs[i].msg_hdr.msg_namelen = sizeof(sockaddr_storage);
    b.in_msgs[i].msg_hdr.msg_flags = 0;
  }
  const int received = recvmmsg(fd_, b.in_msgs.data(), kBatch, MSG_DONTWAIT, nullptr);
  if (received <= 0) return;
  counters_.datagrams_received.fetch_add(received, std::memory_order_relaxed);

  // One snapshot for the whole batch: every tick in it sees the same scene.
  const scene::SceneSnapshot& scene = publisher_.Acquire(reader_);
  int replies = 0;
  for (int i = 0; i < received; ++i) {
    if (HandleDatagram(i, replies, now_ns, scene)) ++replies;
  }
  publisher_.Release(reader_);
  SendReplies(replies);
}

bool RealtimeChannel::HandleDatagram(int index, int reply, int64_t now_ns,
                                     const scene::SceneSnapshot& scene) {
  Batch& b = *batch_;
  const mmsghdr& message = b.in_msgs[index];
  const std::span<const uint8_t> datagram(b.in_data[index].data(), message.msg_len);

  // Size, then the message, then whose it is, then its tag, then its freshness.
  if ((message.msg_hdr.msg_flags & MSG_TRUNC) || datagram.size() > kMaxStateSize) {
    counters_.oversized.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  DeviceStateSample state;
  if (ParseState(datagram, state) != DatagramError::kNone) {
    counters_.malformed.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  const int slot_index = sessions_.FindLive(state.session_id);
  if (slot_index < 0) {
    // an authentic state of a session that ended lately: say that it ended
    // (each sequence once, increasing: a replayed datagram is not reflected)
    EndedSession* ended = FindEnded(state.session_id);
    if (ended != nullptr && CheckTag(datagram, ended->tag_key) && state.sequence > ended->last_sequence) {
      ended->last_sequence = state.sequence;
      counters_.ended_session.fetch_add(1, std::memory_order_relaxed);
      std::memcpy(&ended->peer, &b.in_peer[index], message.msg_hdr.msg_namelen);
      DeviceCommandSample command;
      command.session_id = ended->id;
      command.sequence = state.sequence;
      command.echo_send_time_ns = state.send_time_ns;
      command.scene_version = scene.version();
      command.avatar_W = state.p_WD;
      command.p_command_W = state.p_WD;
      command.flags = ended->flags;
      return QueueDatagram(command, ended->tag_key, ended->peer, message.msg_hdr.msg_namelen, reply);
    }
    counters_.unknown_session.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  SessionSlot& slot = sessions_.slot(slot_index);
  if (!CheckTag(datagram, slot.tag_key)) {
    counters_.bad_tag.fetch_add(1, std::memory_order_relaxed);
    ++slot.telemetry.bad_tag;
    PublishTelemetry(slot, slot.state.load(std::memory_order_relaxed));
    return false;
  }
  switch (slot.replay.Check(state.sequence)) {
    case ReplayVerdict::kReplayed:
      counters_.replayed.fetch_add(1, std::memory_order_relaxed);
      ++slot.telemetry.replayed;
      PublishTelemetry(slot, slot.state.load(std::memory_order_relaxed));
      return false;
    case ReplayVerdict::kReordered:
      counters_.reordered.fetch_add(1, std::memory_order_relaxed);
      ++slot.telemetry.reordered;
      PublishTelemetry(slot, slot.state.load(std::memory_order_relaxed));
      return false;
    case ReplayVerdict::kFresh:
      break;
  }

  // A fresh, authentic state: it names where the device is now.
  const auto send_ns = static_cast<int64_t>(std::min<uint64_t>(state.send_time_ns, INT64_MAX));
  const double dt = StepSeconds(slot, send_ns, now_ns);
  std::memcpy(&slot.peer, &b.in_peer[index], message.msg_hdr.msg_namelen);
  slot.peer_size = message.msg_hdr.msg_namelen;
  slot.last_state_ns = now_ns;
  slot.last_send_ns = send_ns;
  slot.next_silent_tick_ns = now_ns + slot.period_ns + slot.period_ns / 2;
  next_pass_ns_ = std::min(next_pass_ns_, slot.next_silent_tick_ns);
  any_live_ = true;
  slot.ramp_done = false;
  slot.state.store(SlotState::kActive, std::memory_order_release);

  SessionTelemetrySample& telemetry = slot.telemetry;
  // the device's end of the channel as it reports it; the state silent ticks predict on
  slot.channel.ReceiveState(now_ns, state.p_WD, state.v_WD, state.energy_in);
  telemetry.device_energy = {state.energy_in, state.energy_out};
  telemetry.states_held = state.states_held;
  telemetry.keepalives += state.keepalive ? 1 : 0;
  slot.state_sequence = state.sequence;
  slot.state_send_ns = state.send_time_ns;

  force::DeviceInput& input = slot.last_input;
  input.fresh = true;
  input.v_WD = state.v_WD;
  input.f_held_W = state.f_held_W;
  input.f_sensed_W = state.f_sensed_W;
  const int64_t tick_start_ns = MonotonicNowNs();
  const Vector3 step = StepInput(slot, scene, state.p_WD, dt);
  const force::SessionCounters before = slot.render->counters();
  const force::TickOutput output = slot.render->Tick(scene, input, dt);
  ObserveTick(slot, output, step, before);
  const double tick_us = static_cast<double>(MonotonicNowNs() - tick_start_ns) * 1e-3;

  telemetry.rtt_us = state.rtt_us;
  telemetry.last_sequence = state.sequence;
  ++telemetry.states_received;
  telemetry.tick_us_max = std::max(telemetry.tick_us_max, tick_us);
  if (slot.local_model) {
    telemetry.model_version = state.model_version;
    telemetry.device_avatar_W = state.avatar_W;
  }
  // the answer, unless a deadband holds it back
  const uint32_t flags = output.overrun ? v1::COMMAND_FLAGS_OVERRUN : v1::COMMAND_FLAGS_NONE;
  bool queued = false;
  if (!slot.channel.deadband().on() || flags != v1::COMMAND_FLAGS_NONE || state.keepalive ||
      slot.channel.AnswerDue(now_ns, OutOfBand(slot, output, false))) {
    queued = QueueCommand(slot, output, state.sequence, state.send_time_ns, scene.version(), flags, reply, now_ns);
  } else {
    ++telemetry.commands_held;
    RecordOutput(slot, output, scene.version());
  }
  PublishTelemetry(slot, slot.state.load(std::memory_order_relaxed));
  return queued;
}

void RealtimeChannel::TickSilentSessions(int64_t now_ns) {
  int replies = 0;
  const scene::SceneSnapshot& scene = publisher_.Acquire(reader_);
  const int used_slots = sessions_.used_slots();
  // the next pass: when the first live session is due, at the latest kIdlePassNs from now
  next_pass_ns_ = now_ns + kIdlePassNs;
  any_live_ = false;
  for (int i = 0; i < used_slots; ++i) {
    SessionSlot& slot = sessions_.slot(i);
    const SlotState state = slot.state.load(std::memory_order_acquire);
    if (!IsLive(state)) continue;
    if (HousekeepSession(slot, state, now_ns, scene, replies)) ++replies;
    const SlotState after = slot.state.load(std::memory_order_relaxed);
    if (!IsLive(after)) continue;
    next_pass_ns_ = std::min(next_pass_ns_, NextDueNs(slot, after));
    any_live_ = true;
  }
  publisher_.Release(reader_);
  SendReplies(replies);
}

int64_t RealtimeChannel::NextDueNs(const SessionSlot& slot, SlotState state) {
  // its timeout, and (once it has sent a state) its next silent tick
  if (state == SlotState::kWaiting) return slot.opened_ns + slot.timeout_ns;
  return std::min(slot.last_state_ns + slot.timeout_ns, slot.next_silent_tick_ns);
}

bool RealtimeChannel::HousekeepSession(SessionSlot& slot, SlotState state, int64_t now_ns,
                                       const scene::SceneSnapshot& scene, int reply) {
  // Closed by the control thread: hand the slot back.
  if (slot.close_requested.load(std::memory_order_acquire)) {
    RememberEnded(slot, v1::COMMAND_FLAGS_SESSION_CLOSED);
    PublishTelemetry(slot, SlotState::kClosed);
    slot.state.store(SlotState::kClosed, std::memory_order_release);
    return false;
  }
  // Silent for the whole timeout (or never heard from): reclaimed.
  const int64_t last_ns = state == SlotState::kWaiting ? slot.opened_ns : slot.last_state_ns;
  if (now_ns - last_ns >= slot.timeout_ns) {
    counters_.sessions_timed_out.fetch_add(1, std::memory_order_relaxed);
    RememberEnded(slot, v1::COMMAND_FLAGS_SESSION_TIMED_OUT);
    PublishTelemetry(slot, SlotState::kTimedOut);
    slot.state.store(SlotState::kTimedOut, std::memory_order_release);
    return false;
  }
  if (state == SlotState::kWaiting || now_ns < slot.next_silent_tick_ns) return false;

  // A state is late: tick on the last one, so the watchdog counts the silence. A
  // deadband session within its keep-alive (and a period) renders the last state
  // predicted on at its velocity instead: the device sends none while that holds.
  slot.next_silent_tick_ns += slot.period_ns;
  const double dt = NsToSeconds(slot.period_ns);
  force::DeviceInput& input = slot.last_input;
  const bool predicted = Impedance(slot) && slot.channel.Predicts(now_ns, slot.period_ns);
  input.fresh = predicted;
  Vector3 step = Vector3::Zero();
  if (predicted) {
    input.v_WD = slot.channel.state_v_W();
    step = StepInput(slot, scene, slot.channel.Predict(now_ns), dt);
    ++slot.telemetry.predicted_ticks;
  }
  const force::SessionCounters before = slot.render->counters();
  const force::TickOutput output = slot.render->Tick(scene, input, dt);
  ObserveTick(slot, output, step, before);
  const auto& control = slot.render->settings().control;
  const bool watchdog_tripped = NsToSeconds(now_ns - slot.last_state_ns) >= control.watchdog_timeout_s;
  if (watchdog_tripped && state == SlotState::kActive) {
    slot.state.store(SlotState::kRamping, std::memory_order_release);
  }
  // Once the watchdog ramps, tell the device, until the force is zero (nothing to
  // tell a device whose last command was already zero).
  bool queued = false;
  if (watchdog_tripped && !slot.ramp_done) {
    const bool nothing_to_ramp = output.f_W.isZero(0) && slot.channel.f_sent_W().isZero(0);
    queued = !nothing_to_ramp &&
             QueueCommand(slot, output, 0, 0, scene.version(), v1::COMMAND_FLAGS_WATCHDOG, reply, now_ns);
    slot.ramp_done = output.f_W.isZero(0);
  } else if (predicted) {
    // a prediction the device must hear of: for the state it was made from
    if (OutOfBand(slot, output, true)) {
      queued = QueueCommand(slot, output, slot.state_sequence, slot.state_send_ns, scene.version(),
                            v1::COMMAND_FLAGS_PREDICTED, reply, now_ns);
    } else {
      RecordOutput(slot, output, scene.version());
    }
  }
  PublishTelemetry(slot, slot.state.load(std::memory_order_relaxed));
  return queued;
}

bool RealtimeChannel::QueueCommand(SessionSlot& slot, const force::TickOutput& output, uint64_t sequence,
                                   uint64_t echo_ns, uint64_t scene_version, uint32_t flags, int reply,
                                   int64_t now_ns) {
  DeviceCommandSample command;
  command.session_id = slot.id;
  command.sequence = sequence;
  command.echo_send_time_ns = echo_ns;
  command.scene_version = scene_version;
  const bool admittance = slot.render->settings().device.mode == force::DeviceMode::kAdmittance;
  if (!admittance) command.f_W = output.f_W;
  command.p_command_W = output.p_command_W;
  command.avatar_W = output.avatar_W;
  command.contact = output.contact;
  command.flags = flags;
  command.energy_in = slot.channel.end().energy().in;
  command.energy_out = slot.channel.end().energy().out;
  command.commands_held = slot.telemetry.commands_held;
  command.command_number = slot.command_number + 1;
  SessionTelemetrySample& telemetry = slot.telemetry;
  // a local model the device does not hold yet: its fragments in turn
  if (slot.local_model) {
    const EncodedModel& model = slot.models->Newest();
    if (model.session_id == slot.id && model.version > telemetry.model_version) {
      if (model.version != slot.sending_version) {
        slot.sending_version = model.version;
        slot.next_fragment = 0;
        slot.fragments_sent = 0;
      }
      command.model = Fragment(std::span<const uint8_t>(model.bytes.data(), model.size), model.version,
                               slot.next_fragment);
      slot.next_fragment = (slot.next_fragment + 1) % command.model.count;
      ++slot.fragments_sent;
      ++telemetry.model_fragments_sent;
    }
  }

  RecordOutput(slot, output, scene_version);
  if (!QueueDatagram(command, slot.tag_key, slot.peer, slot.peer_size, reply)) return false;
  ++telemetry.commands_sent;
  ++slot.command_number;
  slot.channel.RecordCommand(command.f_W, now_ns);
  return true;
}

bool RealtimeChannel::QueueDatagram(const DeviceCommandSample& command, const TagKey& key,
                                    const sockaddr_storage& peer, socklen_t peer_size, int reply) {
  Batch& b = *batch_;
  if (reply >= static_cast<int>(b.out_msgs.size()) || peer_size == 0) return false;
  const std::size_t size = EncodeCommand(command, key, b.out_data[reply]);
  if (size == 0) return false;
  b.out_iov[reply] = {b.out_data[reply].data(), size};
  b.out_msgs[reply] = {};
  b.out_msgs[reply].msg_hdr.msg_iov = &b.out_iov[reply];
  b.out_msgs[reply].msg_hdr.msg_iovlen = 1;
  // sendmmsg only reads the address
  b.out_msgs[reply].msg_hdr.msg_name = const_cast<sockaddr_storage*>(&peer);
  b.out_msgs[reply].msg_hdr.msg_namelen = peer_size;
  return true;
}

void RealtimeChannel::RememberEnded(SessionSlot& slot, uint32_t flags) {
  EndedSession& ended = ended_[next_ended_];
  next_ended_ = (next_ended_ + 1) % kEndedRemembered;
  ended.id = slot.id;
  ended.tag_key = slot.tag_key;
  ended.flags = flags;
  ended.peer = slot.peer;
  ended.last_sequence = slot.replay.newest();
}

RealtimeChannel::EndedSession* RealtimeChannel::FindEnded(uint32_t id) {
  if (id == 0) return nullptr;
  for (EndedSession& ended : ended_) {
    if (ended.id == id) return &ended;
  }
  return nullptr;
}

void RealtimeChannel::SendReplies(int count) {
  int sent = 0;
  while (sent < count) {
    const int n = sendmmsg(fd_, batch_->out_msgs.data() + sent, count - sent, MSG_DONTWAIT);
    if (n <= 0) {
      // A full socket buffer or an unreachable peer: those commands are lost, counted.
      counters_.send_errors.fetch_add(count - sent, std::memory_order_relaxed);
      return;
    }
    counters_.commands_sent.fetch_add(n, std::memory_order_relaxed);
    sent += n;
  }
}

void RealtimeChannel::PublishTelemetry(SessionSlot& slot, SlotState state) {
  slot.telemetry.state = state;
  slot.telemetry.render = slot.render->counters();
  slot.published.Write(slot.telemetry);
}

}  // namespace hapticd::net
