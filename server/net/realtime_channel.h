#pragma once
// The realtime channel: one UDP socket and the thread that renders every session.
//
// Theory of operation. The thread waits (ppoll) for datagrams or the housekeeping pass
// (4), whichever comes first, then:
//   1. receives every queued datagram in one recvmmsg batch;
//   2. for each: size -> parse -> session lookup -> tag -> replay window; a datagram that
//      fails a step is counted under that step's name and dropped; a good one is
//      rendered at once (RenderSession::Tick on the current snapshot, under the
//      session's work budget: a tick over it sends the last safe force, flagged
//      OVERRUN, so no session's tick can hold up the others for long) and its command
//      joins the reply batch;
//   3. sends the replies in one sendmmsg;
//   4. housekeeping: ticks sessions whose states stopped, once a period: the watchdog
//      ramps their force down (sent to the last address, flagged); a deadband session
//      within its keep-alive renders its last state predicted on instead (flagged
//      PREDICTED when its command leaves the band); a session silent for
//      its timeout is handed back to the control thread as kTimedOut, a closed one as
//      kClosed. The pass runs when the first session is due (its next silent tick, 1.5
//      periods after its last state, or its timeout), at most once a millisecond by the
//      clock and at least every 2 ms while a session lives (with none, the thread
//      sleeps until a datagram comes or the session table's doorbell rings: a session
//      opened, or Stop); one due within 0.75 ms runs at once after a batch of
//      datagrams. Sessions that stream in time are never due, so their datagrams are
//      the thread's only wake-ups.
// The channel's server side (remote/renderer_channel.h, the code hapticd-sim's renderer
// runs too): an impedance session's avatar input steps towards the device's newest
// position, or a deadband's prediction of it, through its RendererEnd (under TDPA as
// far as its port lets it), whose energies go down with the commands; the device's
// come up with the states. A deadband session's commands go out only as
// hapticd.v1.OpenSession.deadband says; the rest are counted as held.
// Each session's key is prepared for tagging once (TagKey: the BLAKE2b state after the
// key's block), on its first datagram.
// A session that ended (closed or timed out) is remembered, id and key, among the last
// kEndedRemembered: an authentic state for it is answered with a zero command flagged
// SESSION_CLOSED or SESSION_TIMED_OUT, so its device can tell the end from packet loss.
// Everything it touches is preallocated when the channel or the session is created: it
// allocates nothing, throws nothing, logs nothing and shares no lock (session_table.h,
// snapshot_publisher.h).
#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <asio/ip/udp.hpp>
#include "server/net/session_table.h"
#include "server/scene/snapshot_publisher.h"

namespace hapticd::net {

// Datagrams counted by why they were dropped, and what was sent. Written by the
// realtime thread only.
struct RealtimeCounters {
  std::atomic<uint64_t> datagrams_received{0};
  std::atomic<uint64_t> commands_sent{0};
  std::atomic<uint64_t> malformed{0};
  std::atomic<uint64_t> oversized{0};
  std::atomic<uint64_t> unknown_session{0};
  std::atomic<uint64_t> bad_tag{0};
  std::atomic<uint64_t> replayed{0};
  std::atomic<uint64_t> reordered{0};
  std::atomic<uint64_t> send_errors{0};
  std::atomic<uint64_t> sessions_timed_out{0};
  // States of a session that ended lately, answered with an ended command.
  std::atomic<uint64_t> ended_session{0};
};

// CLOCK_MONOTONIC in ns: the clock of every timestamp the server takes.
int64_t MonotonicNowNs();

class RealtimeChannel {
 public:
  // Binds endpoint (port 0: a free one). Throws std::system_error when it cannot.
  RealtimeChannel(const asio::ip::udp::endpoint& endpoint, SessionTable& sessions,
                  scene::SnapshotPublisher& publisher);
  ~RealtimeChannel();
  RealtimeChannel(const RealtimeChannel&) = delete;
  RealtimeChannel& operator=(const RealtimeChannel&) = delete;

  asio::ip::udp::endpoint local_endpoint() const { return local_endpoint_; }
  const RealtimeCounters& counters() const { return counters_; }

  // Starts the realtime thread, at SCHED_FIFO priority when priority > 0; returns
  // whether that priority was granted. Stop joins the thread. Both idempotent.
  bool Start(int priority = 0);
  void Stop();

 private:
  static constexpr int kBatch = 64;

  void Run();
  void ReceiveAndReply(int64_t now_ns);
  // Renders one datagram; true when a command was queued in slot `reply` of the batch.
  bool HandleDatagram(int index, int reply, int64_t now_ns, const scene::SceneSnapshot& scene);
  // The housekeeping pass over every live session; sets next_pass_ns_.
  void TickSilentSessions(int64_t now_ns);
  // One live session's share of it: hand it back when closed or timed out, else tick
  // it when its state is late. True when a command was queued in slot `reply`.
  bool HousekeepSession(SessionSlot& slot, SlotState state, int64_t now_ns, const scene::SceneSnapshot& scene,
                        int reply);
  // When a live session in state next needs the pass: its next silent tick or timeout.
  static int64_t NextDueNs(const SessionSlot& slot, SlotState state);
  // Encodes command into the reply batch at reply for slot's peer; false if it did not fit.
  bool QueueCommand(SessionSlot& slot, const force::TickOutput& output, uint64_t sequence,
                    uint64_t echo_ns, uint64_t scene_version, uint32_t flags, int reply, int64_t now_ns);
  // Encodes command, tagged with key, into the reply batch at reply for peer.
  bool QueueDatagram(const DeviceCommandSample& command, const TagKey& key, const sockaddr_storage& peer,
                     socklen_t peer_size, int reply);

  // A session that ended, as its device's late states are answered.
  struct EndedSession {
    uint32_t id = 0;  // 0: none
    TagKey tag_key;
    uint32_t flags = 0;  // COMMAND_FLAGS_SESSION_CLOSED or _TIMED_OUT
    sockaddr_storage peer{};
    uint64_t last_sequence = 0;  // the highest state answered (or seen while it lived)
  };
  static constexpr int kEndedRemembered = 64;
  void RememberEnded(SessionSlot& slot, uint32_t flags);
  // The remembered session with this id, or nullptr.
  EndedSession* FindEnded(uint32_t id);
  void SendReplies(int count);
  // Publishes the slot's telemetry as being in state (before the state itself is
  // handed over, so the control thread reads the final sample).
  void PublishTelemetry(SessionSlot& slot, SlotState state);

  SessionTable& sessions_;
  scene::SnapshotPublisher& publisher_;
  int reader_ = -1;
  int fd_ = -1;
  asio::ip::udp::endpoint local_endpoint_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  RealtimeCounters counters_;

  struct Batch;  // the recvmmsg/sendmmsg buffers
  std::unique_ptr<Batch> batch_;
  std::array<EndedSession, kEndedRemembered> ended_{};
  int next_ended_ = 0;
  // When the housekeeping pass is next due (at most: a fresh state may bring it forward).
  int64_t next_pass_ns_ = 0;
  // Whether the last pass (or a state since) found a live session: without one the
  // thread waits with no timeout.
  bool any_live_ = true;
};

}  // namespace hapticd::net
