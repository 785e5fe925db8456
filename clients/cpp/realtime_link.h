#pragma once
// The device end of one session's realtime channel: one UDP socket, connected to the
// server's endpoint (the kernel then drops datagrams from anyone else).
//
// Theory of operation. Each tick the loop sends one DeviceState (Send), then waits for
// the DeviceCommand that answers it (LinkSet::AwaitAll) until its budget runs out, then
// gives up on it (Expire). Every datagram that arrives is checked in this order and
// counted under the first check it fails:
//   size <= 512 bytes -> tag under the session key -> parses -> our session id ->
//   sequence: newer than the last sent: bad (never sent); 0 (a server watchdog
//             command), older than the last kWindow states, already answered or
//             for a state whose send failed: stale; the last state's, within its wait: answered; any other state's
//             first answer: late; flagged PREDICTED (a deadband session's server
//             rendering a state predicted on): predicted, the newest when its
//             command_number is.
// Every authentic command of the session also reports the server's end of the channel
// (its energies, the commands its deadband held, how many it has sent): the link keeps
// the largest of each (all non-decreasing, so a late or reordered one changes nothing).
// The round trip is taken twice: from just before the send to the loop reading the
// command (CLOCK_MONOTONIC, what the loop experiences; answered commands only), and to
// the kernel's arrival stamp of the datagram (SO_TIMESTAMPNS, CLOCK_REALTIME on both
// ends: the wire's share, without the loop's wake-up; late commands too, into the sink
// set by set_wire_rtt_sink). Everything is preallocated: Send and Drain allocate nothing.
//
// Besides the last state's answer, the link keeps the newest command that came (answered
// or late): across a delay longer than a tick every command is late, and the device
// renders the newest it has. A local-model session's model fragments go to a sink from
// every authentic command of the session, stale ones too (the fragments are the same).
//
// Echo mode (the benchmark's baseline) sends the same states to a plain UDP echo: the
// answer is the state itself, checked the same way and read back as a command with no
// force.
#include <array>
#include <cstdint>
#include <span>
#include <vector>
#include <sys/epoll.h>
#include <asio/ip/udp.hpp>

#include "clients/cpp/latency_stats.h"
#include "server/net/datagram_codec.h"

namespace hapticd::proxy {

// What answers the states.
enum class LinkPeer {
  kServer,  // hapticd: a DeviceCommand
  kEcho,    // a plain UDP echo: the DeviceState sent
};

// A link's datagrams, by fate.
struct LinkCounters {
  uint64_t sent = 0;           // states handed to the kernel
  uint64_t send_errors = 0;    // sends the kernel refused (and ICMP errors reported back)
  uint64_t answered = 0;       // commands for the last state, within its wait
  uint64_t late = 0;           // first commands for a state whose wait had ended
  uint64_t stale = 0;          // server watchdog commands, duplicates, answers too old to place
  uint64_t bad = 0;            // oversized, bad tag, malformed, another session, never sent
  uint64_t predicted = 0;      // deadband: commands for a state predicted on (COMMAND_FLAGS_PREDICTED)

  LinkCounters& operator+=(const LinkCounters& other);
  // States whose command never came: sent - answered - late (under a deadband this
  // includes those whose answer the server held back: ServerEnd::commands_held).
  uint64_t lost() const { return sent - answered - late; }
};

// The server's end of a session's channel as its commands report it: the largest of
// each so far.
struct ServerEnd {
  double energy_in = 0;         // J: the server's port (two_port_passivity.h)
  double energy_out = 0;
  uint64_t commands_held = 0;   // held back by its deadband
  uint64_t commands_sent = 0;   // the largest command_number

  ServerEnd& operator+=(const ServerEnd& other);
};

// Takes the model fragments of a local-model session's commands (on the loop's thread,
// inside Drain; the fragment's bytes are valid only during the call).
class FragmentSink {
 public:
  virtual ~FragmentSink() = default;
  virtual void Offer(const net::ModelFragmentView& fragment) = 0;
};

class RealtimeLink {
 public:
  // How many recent states a link remembers (their send times and whether answered): a
  // second at 1 kHz, so that an answer across the network lab's delays (up to 100 ms
  // each way, and more with jitter) is still placed, and its round trip measured.
  static constexpr int kWindow = 1024;

  // A socket connected to endpoint for session session_id under key. Throws
  // std::system_error naming the endpoint when the socket cannot be made or connected.
  RealtimeLink(uint32_t session_id, const net::SessionKey& key, const asio::ip::udp::endpoint& endpoint,
               LinkPeer peer = LinkPeer::kServer);
  ~RealtimeLink();
  RealtimeLink(const RealtimeLink&) = delete;
  RealtimeLink& operator=(const RealtimeLink&) = delete;

  int fd() const { return fd_; }
  uint32_t session_id() const { return session_id_; }

  // Sends state as the next sequence (from 1), stamped now: fills its session_id,
  // sequence and send_time_ns (CLOCK_MONOTONIC). False when the send failed (counted).
  bool Send(net::DeviceStateSample& state);
  // The last state's send stamp, CLOCK_MONOTONIC ns (0 before the first).
  int64_t send_ns() const { return send_mono_ns_; }

  // Reads queued datagrams without waiting, up to the one that answers the last state
  // (every queued one when it was answered already). True once the last state's command
  // has arrived within its wait (then command() holds it).
  bool Drain();

  // Ends the wait for the last state: if its command still comes, it counts as late.
  void Expire();

  // Whether the last state's command arrived within its wait, and that command.
  bool answered() const { return wait_ == Wait::kAnswered; }
  const net::DeviceCommandSample& command() const { return command_; }
  // The answered command's round trips, ns: to the loop reading it, and to the kernel's
  // arrival stamp (0 when the kernel gave none).
  int64_t rtt_ns() const { return rtt_ns_; }
  int64_t wire_rtt_ns() const { return wire_rtt_ns_; }

  const LinkCounters& counters() const { return counters_; }
  const ServerEnd& server_end() const { return server_end_; }

  // The server said the session has ended: COMMAND_FLAGS_SESSION_CLOSED or
  // _TIMED_OUT from an authentic command; 0 while it lives.
  uint32_t ended_flags() const { return ended_flags_; }

  // Where every command's wire round trip (answered or late) is recorded; null: nowhere.
  void set_wire_rtt_sink(LatencyStats* sink) { wire_rtt_sink_ = sink; }
  // Where model fragments go; null: nowhere.
  void set_fragment_sink(FragmentSink* sink) { fragment_sink_ = sink; }

  // The newest command that has come, answered or late (its model fragment cleared),
  // and whether one came since the last ClearFresh.
  const net::DeviceCommandSample& newest() const { return newest_; }
  bool fresh() const { return fresh_; }
  void ClearFresh() { fresh_ = false; }

 private:
  enum class Wait { kNone, kWaiting, kAnswered, kExpired };

  // Checks one received datagram and takes it as the answer when it is one.
  void Accept(std::span<const uint8_t> datagram, bool truncated, int64_t arrival_real_ns);
  // Parses a good-tagged datagram as what the peer answers with; false when malformed.
  bool Parse(std::span<const uint8_t> datagram);
  // Takes incoming_ as the newest command when it is newer (by command_number when both
  // have one, else by sequence).
  void TakeIfNewest();

  uint32_t session_id_;
  net::TagKey key_;  // prepared once: each tag is one compression
  LinkPeer peer_;
  int fd_ = -1;

  uint64_t last_sequence_ = 0;  // the last state sent
  int64_t send_mono_ns_ = 0;
  Wait wait_ = Wait::kNone;     // of the last state
  // The last kWindow states by sequence % kWindow: CLOCK_REALTIME send stamp (0: the
  // send failed) and whether a command for it has come.
  std::array<int64_t, kWindow> send_real_ns_{};
  std::array<bool, kWindow> replied_{};
  LatencyStats* wire_rtt_sink_ = nullptr;
  FragmentSink* fragment_sink_ = nullptr;
  net::DeviceCommandSample newest_;
  bool fresh_ = false;
  net::DeviceCommandSample command_;  // the answer, once answered()
  net::DeviceCommandSample incoming_;  // the datagram being checked
  net::DeviceStateSample echoed_;      // echo mode: the state read back
  int64_t rtt_ns_ = 0;
  int64_t wire_rtt_ns_ = 0;
  uint32_t ended_flags_ = 0;
  LinkCounters counters_;
  ServerEnd server_end_;

  std::array<uint8_t, 2048> send_buffer_;
  std::array<uint8_t, 2048> receive_buffer_;
  alignas(8) std::array<uint8_t, 128> control_buffer_;  // the arrival stamp's cmsg
};

// Several links awaited together (epoll): the loop's wait for a tick's commands.
class LinkSet {
 public:
  // The links stay owned by the caller and must outlive the set. Throws
  // std::system_error when epoll cannot be set up.
  explicit LinkSet(std::span<RealtimeLink* const> links);
  ~LinkSet();
  LinkSet(const LinkSet&) = delete;
  LinkSet& operator=(const LinkSet&) = delete;

  // Reads datagrams as they come until every link's last state is answered or
  // CLOCK_MONOTONIC reaches deadline_ns; returns how many links were answered in this
  // wait. With the deadline already past it returns 0 at once (what came stays queued:
  // late). Real-time safe.
  int AwaitAll(int64_t deadline_ns);

 private:
  std::vector<RealtimeLink*> links_;
  std::vector<uint8_t> counted_;  // per link: answered and counted in this wait
  std::vector<epoll_event> events_;  // one per link
  int epoll_fd_ = -1;
  bool have_pwait2_ = true;  // epoll_pwait2 (ns timeouts); else epoll_wait in whole ms
};

}  // namespace hapticd::proxy
