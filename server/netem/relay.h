#pragma once

// hapticd-netem's relay: devices send to one listening UDP socket; each device (its
// source address) becomes a flow with its own socket towards the server, so the
// server's replies come back per flow and are relayed to that device from the listening
// socket. Every datagram, each way, gets its fate from the flow's Impairment for that
// direction and waits in one queue ordered by release time; a timerfd armed at the
// earliest release (an absolute deadline) wakes the loop to send what is due.
//
// Bounds: at most queue_limit datagrams and kMaxQueuedBytes bytes wait per direction
// (more are dropped and counted as overflow); at most max_flows devices at once (a new one takes the place of the
// flow silent longest, if silent for flow_idle_s, else its datagrams are refused); the
// receive buffers are fixed. Datagrams are relayed as bytes, never parsed.

#include <netinet/in.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "server/netem/delay_histogram.h"
#include "server/netem/impairment.h"
#include "server/netem/netem_options.h"

namespace hapticd::netem {

// What one direction's queue may hold in datagram bytes at once.
inline constexpr int64_t kMaxQueuedBytes = int64_t{64} << 20;

struct DirectionStats {
  int64_t in = 0;          // datagrams received
  int64_t out = 0;         // datagrams sent (copies included)
  int64_t lost = 0;        // dropped by the loss model
  int64_t duplicated = 0;  // second copies queued
  int64_t reordered = 0;   // sent at once, skipping the delay
  int64_t overflow = 0;    // dropped: the queue was full
  int64_t unsent = 0;      // the send failed, or the flow was replaced meanwhile
  DelayHistogram applied;  // release - arrival: the delay given (ns)
  DelayHistogram late;     // send - release: the relay's own error (ns)
};

class Relay {
 public:
  // Binds the listening socket (throws std::runtime_error naming the address when it
  // cannot) and takes the real-time priority when granted.
  explicit Relay(const NetemOptions& options);
  ~Relay();
  Relay(const Relay&) = delete;
  Relay& operator=(const Relay&) = delete;

  // The bound listening endpoint, "HOST:PORT".
  std::string listen_endpoint() const;
  // Whether SCHED_FIFO was granted.
  bool realtime() const { return realtime_; }

  // Relays until stop_fd is readable or duration_s has passed (0: no limit); then
  // takes in what has arrived, so that the summary counts every datagram that
  // reached the relay (what is still delayed is counted as held, not sent).
  void Run(int stop_fd);

  // One JSON object: each direction's counts and delays, the flows.
  std::string SummaryJson() const;

 private:
  struct Flow;
  struct Pending {
    int64_t release_ns;
    uint64_t order;  // arrival order: equal release times leave in it
    int direction;   // 0: device -> server, 1: server -> device
    int flow;        // slot
    uint64_t generation;  // the slot's flow when queued
    int buffer;      // index in buffers_
    int bytes;
    // The heap's order: the later release (of equal ones, the later arrival) sinks.
    static bool Later(const Pending& a, const Pending& b) {
      return a.release_ns != b.release_ns ? a.release_ns > b.release_ns : a.order > b.order;
    }
  };

  void ReceiveFromDevices(int64_t now_ns);
  void ReceiveFromServer(int slot, int64_t now_ns);
  void Enqueue(int direction, int slot, const uint8_t* data, int bytes, int64_t now_ns);
  int FlowFor(const sockaddr_in& device, int64_t now_ns);
  void SendDue(int64_t now_ns);
  void ReceiveWaiting(int64_t now_ns);
  void ArmTimer();

  NetemOptions options_;
  int listen_fd_ = -1;
  int timer_fd_ = -1;
  bool realtime_ = false;
  sockaddr_in forward_{};
  std::vector<std::unique_ptr<Flow>> flows_;  // slots; null: free
  int flows_seen_ = 0;
  int64_t refused_ = 0;
  int64_t truncated_ = 0;
  uint64_t next_order_ = 0;
  std::vector<Pending> queue_;  // a min-heap on (release_ns, order)
  int queued_[2] = {0, 0};
  int64_t queued_bytes_[2] = {0, 0};
  std::vector<std::vector<uint8_t>> buffers_;
  std::vector<int> free_buffers_;
  DirectionStats stats_[2];
};

}  // namespace hapticd::netem
