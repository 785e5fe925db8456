#pragma once

// One direction of the simulated network between device and renderer, in whole ticks.
//
// Theory of operation. Each message sent at tick k draws, from the channel's own
// std::mt19937_64, first whether it is lost (u < loss, u uniform in [0, 1)), then its
// jitter (jitter_s * u', u' uniform in [0, 1); both draws happen for every message, so
// the sequence of draws does not depend on the outcomes). A message that is not lost
// arrives at the first tick whose time is at or after its send time plus its delay:
//   arrival = k + ceil((delay_s + jitter) * rate_hz - 1e-9),
// so a 5 ms delay at 1 kHz is exactly 5 ticks, and a zero delay delivers in the same
// tick. The receiver takes, at each tick, the newest message (highest sequence number)
// that has arrived by then and is newer than the last one it took; older messages that
// arrive late are dropped, as a real-time receiver would drop them.

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "server/sim/scenario.h"

namespace hapticd::sim {

// The draws for one message.
struct Delivery {
  bool lost = false;
  int64_t latency_ticks = 0;  // ticks from sending to arrival, >= 0
};

// Draws deliveries for one direction of a channel.
class DeliveryDrawer {
 public:
  // stream tells the two directions apart: the generator is seeded with
  // std::seed_seq{seed low 32 bits, seed high 32 bits, stream}.
  DeliveryDrawer(const ChannelSpec& channel, double rate_hz, uint32_t stream);
  Delivery Draw();

 private:
  // Uniform in [0, 1) from the top 53 bits of one 64-bit draw (the same on every
  // standard library, unlike std::uniform_real_distribution).
  double DrawUniform();

  ChannelSpec channel_;
  double rate_hz_;
  std::mt19937_64 random_;
};

template <typename Message>
class Channel {
 public:
  // horizon_tick: messages that would arrive at or after it (after the run) are not kept,
  // so that a delay longer than the run does not pile them up.
  Channel(const ChannelSpec& channel, double rate_hz, uint32_t stream,
          int64_t horizon_tick = std::numeric_limits<int64_t>::max())
      : drawer_(channel, rate_hz, stream), horizon_tick_(horizon_tick) {}

  // Sends message at tick (ticks are sent in increasing order; tick + any latency must not
  // overflow, which DeliveryDrawer's cap ensures for ticks below 2^62).
  void Send(int64_t tick, const Message& message) {
    const Delivery delivery = drawer_.Draw();
    ++sent_;
    if (delivery.lost) {
      ++lost_;
      return;
    }
    const int64_t arrival_tick = tick + delivery.latency_ticks;
    if (arrival_tick >= horizon_tick_) return;
    in_flight_.push_back({sent_, arrival_tick, message});
  }

  // The newest message that has arrived by tick and is newer than the last one returned;
  // nullopt when there is none. Older arrivals are counted as stale and dropped.
  std::optional<Message> Receive(int64_t tick) {
    std::optional<Message> newest;
    uint64_t newest_sequence = delivered_sequence_;
    // take what has arrived out of flight, keeping the order of the rest
    size_t kept = 0;
    for (size_t i = 0; i < in_flight_.size(); ++i) {
      InFlight& item = in_flight_[i];
      if (item.arrival_tick > tick) {
        if (kept != i) in_flight_[kept] = std::move(item);
        ++kept;
        continue;
      }
      if (item.sequence > newest_sequence) {
        if (newest) ++superseded_;
        newest_sequence = item.sequence;
        newest = std::move(item.message);
      } else {
        ++stale_;
      }
    }
    in_flight_.resize(kept);
    delivered_sequence_ = newest_sequence;
    return newest;
  }

  uint64_t sent() const { return sent_; }
  uint64_t lost() const { return lost_; }
  // Arrived after a newer message had been taken: dropped.
  uint64_t stale() const { return stale_; }
  // Arrived in the same tick as a newer one: never used.
  uint64_t superseded() const { return superseded_; }

 private:
  struct InFlight {
    uint64_t sequence;  // 1, 2, ... in sending order
    int64_t arrival_tick;
    Message message;
  };

  DeliveryDrawer drawer_;
  int64_t horizon_tick_;
  std::vector<InFlight> in_flight_;
  uint64_t delivered_sequence_ = 0;
  uint64_t sent_ = 0;
  uint64_t lost_ = 0;
  uint64_t stale_ = 0;
  uint64_t superseded_ = 0;
};

}  // namespace hapticd::sim
