#pragma once
// The realtime sessions, in a fixed table shared by the control thread (which opens,
// closes and reclaims them) and the realtime thread (which renders them).
//
// Theory of operation. Each slot has one atomic state, and each state has one owner,
// so no lock is ever shared:
//
//   control:  kFree --fill slot, Reset session--> kWaiting
//   realtime: kWaiting --first state--> kActive --silence--> kRamping --state--> kActive
//             any live state --close_requested--> kClosed
//             any live state --silence >= timeout--> kTimedOut
//   control:  kClosed, kTimedOut --read final telemetry--> kFree
//
// The control thread fills a free slot and publishes it with a release store; the
// realtime thread sees it with an acquire load and from then on owns the slot's render
// state until it hands it back as kClosed or kTimedOut. Telemetry goes the other way
// through a per-slot seqlock: the realtime thread never waits for a reader.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>
#include <netinet/in.h>
#include "server/force/render_session.h"
#include "server/net/datagram_codec.h"
#include "server/net/model_mailbox.h"
#include "server/net/replay_window.h"
#include "server/remote/renderer_channel.h"

namespace hapticd::net {

enum class SlotState : uint8_t { kFree, kWaiting, kActive, kRamping, kClosed, kTimedOut };

// What a session did, as the realtime thread last published it.
struct SessionTelemetrySample {
  SlotState state = SlotState::kFree;
  Vector3 f_W = Vector3::Zero();
  Vector3 p_WD = Vector3::Zero();
  Vector3 avatar_W = Vector3::Zero();
  bool contact = false;
  int touched_object = -1;
  uint64_t scene_version = 0;
  uint32_t rtt_us = 0;
  uint64_t last_sequence = 0;
  uint64_t states_received = 0;
  uint64_t commands_sent = 0;
  uint64_t replayed = 0;
  uint64_t reordered = 0;
  uint64_t bad_tag = 0;
  double tick_us_max = 0;  // longest render tick of the session so far
  force::SessionCounters render;
  // Local-model sessions: the newest model the device said it holds, its own proxy
  // there, and the model fragments sent.
  uint64_t model_version = 0;
  Vector3 device_avatar_W = Vector3::Zero();
  uint64_t model_fragments_sent = 0;
  // The channel's two ports (impedance sessions; the device's as its newest state said).
  remote::PortEnergy server_energy;
  remote::PortEnergy device_energy;
  double drift_m = 0;      // TDPA: the avatar input behind the device's newest position
  double max_drift_m = 0;
  uint64_t tdpa_activations = 0;
  // Deadband sessions.
  uint64_t states_held = 0;  // as the device reported
  uint64_t keepalives = 0;
  uint64_t commands_held = 0;
  uint64_t predicted_ticks = 0;
};

// A single-writer sequence lock around a trivially copyable value: the writer never
// waits; a reader retries while a write is in progress.
template <typename T>
class SeqLocked {
 public:
  void Write(const T& value) {
    const uint32_t seq = seq_.load(std::memory_order_relaxed);
    seq_.store(seq + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    value_ = value;
    seq_.store(seq + 2, std::memory_order_release);
  }
  T Read() const {
    for (;;) {
      const uint32_t before = seq_.load(std::memory_order_acquire);
      T copy = value_;
      std::atomic_thread_fence(std::memory_order_acquire);
      if (!(before & 1) && seq_.load(std::memory_order_relaxed) == before) return copy;
    }
  }

 private:
  std::atomic<uint32_t> seq_{0};
  T value_{};
};

// One session's slot. The fields above the line are written by the control thread
// while the slot is kFree and read-only afterwards; those below belong to the realtime
// thread while the slot is live.
struct SessionSlot {
  std::atomic<SlotState> state{SlotState::kFree};
  std::atomic<bool> close_requested{false};

  uint32_t id = 0;
  SessionKey key{};
  // key, prepared for tagging (one BLAKE2b compression): set with SetKey, so the
  // realtime thread tags with it as it is, without comparing keys on every datagram.
  TagKey tag_key;
  uint64_t owner_connection = 0;  // control thread only: who may close it without the key (0: nobody)
  int64_t period_ns = 1'000'000;
  int64_t timeout_ns = 2'000'000'000;
  std::optional<force::RenderSession> render;
  Vector3 start_W = Vector3::Zero();
  // The device renders from local models (REMOTE_MODE_LOCAL_MODEL), which the model
  // thread cuts into `models`: made for the first such session the slot holds and kept.
  bool local_model = false;
  std::unique_ptr<ModelMailbox> models;
  // ----
  ReplayWindow replay;
  sockaddr_storage peer{};
  socklen_t peer_size = 0;
  int64_t opened_ns = 0;
  int64_t last_state_ns = 0;
  int64_t last_send_ns = 0;  // the device's send stamp of its last fresh state (its clock; 0: none)
  int64_t next_silent_tick_ns = 0;
  force::DeviceInput last_input;
  bool ramp_done = false;  // the watchdog's force reached zero; stop sending
  uint64_t sending_version = 0;  // the model whose fragments go out in turn
  uint32_t next_fragment = 0;
  uint32_t fragments_sent = 0;  // of sending_version, so far
  // The server's side of the channel (impedance sessions; OpenSession.tdpa, .deadband...):
  // its end of two-port passivity, the avatar input it steps towards the device's newest
  // position, the last state (which silent ticks predict on) and the last command sent;
  // the last state's sequence and send stamp (a predicted command's).
  remote::RendererChannel channel;
  uint64_t state_sequence = 0;
  uint64_t state_send_ns = 0;
  uint64_t command_number = 0;  // commands queued so far
  SessionTelemetrySample telemetry;  // the realtime thread's working copy
  SeqLocked<SessionTelemetrySample> published;

  // Control thread, while the slot is kFree: the session's key and its prepared form.
  void SetKey(const SessionKey& new_key) {
    key = new_key;
    tag_key = TagKey(new_key);
  }
};

// A session id carries its slot's index in its low kSlotBits bits (the rest is random),
// so the realtime thread finds a session without searching.
inline constexpr int kSlotBits = 12;
inline constexpr int kMaxSessions = 1 << kSlotBits;

class SessionTable {
 public:
  // capacity in [1, kMaxSessions].
  explicit SessionTable(int capacity);
  ~SessionTable();
  SessionTable(const SessionTable&) = delete;
  SessionTable& operator=(const SessionTable&) = delete;

  int capacity() const { return static_cast<int>(slots_.size()); }
  SessionSlot& slot(int i) { return *slots_[i]; }

  // Control thread: the index of the lowest free slot, or -1 when all are in use.
  int FindFree() const;
  // One past the highest slot ever opened: the realtime thread's scans stop there.
  // Control thread: MarkOpened before publishing a slot's state.
  int used_slots() const { return used_slots_.load(std::memory_order_acquire); }
  void MarkOpened(int index);
  // The doorbell: with no live session the realtime thread sleeps until a datagram comes
  // or this rings. Ring after publishing a slot's state (any thread); the realtime
  // thread waits on doorbell_fd() and clears it with Answer().
  void Ring();
  int doorbell_fd() const { return doorbell_fd_; }
  void Answer();
  // Control thread: the slot of a session that is not free, or -1.
  int FindById(uint32_t id) const;
  // Realtime thread: the live slot (kWaiting, kActive, kRamping) of id, or -1. O(1).
  int FindLive(uint32_t id) const;
  // Control thread: a new id for the slot at index, random in its other bits, never 0
  // and never that of a session still in the table.
  uint32_t MakeId(int index) const;

 private:
  std::vector<std::unique_ptr<SessionSlot>> slots_;
  std::atomic<int> used_slots_{0};
  int doorbell_fd_ = -1;  // an eventfd
};

bool IsLive(SlotState state);

}  // namespace hapticd::net
