#pragma once
// Replay protection for one session's datagrams (after RFC 4303's anti-replay window):
// only a sequence number newer than every one seen so far is accepted, since a haptic
// device's older state is stale by the time a newer one arrived; among the rejected,
// the window of the last 64 numbers tells a replay (seen before) from a late arrival.
#include <cstdint>

namespace hapticd::net {

enum class ReplayVerdict { kFresh, kReplayed, kReordered };

class ReplayWindow {
 public:
  static constexpr uint64_t kWidth = 64;

  // Classifies sequence (>= 1) and, when fresh, records it. A sequence 0 or one older
  // than the window counts as replayed: nothing can tell it from a replay.
  ReplayVerdict Check(uint64_t sequence) {
    if (sequence == 0) return ReplayVerdict::kReplayed;
    if (sequence > newest_) {
      const uint64_t shift = sequence - newest_;
      seen_ = shift >= kWidth ? 0 : seen_ << shift;
      seen_ |= 1;
      newest_ = sequence;
      return ReplayVerdict::kFresh;
    }
    const uint64_t age = newest_ - sequence;
    if (age >= kWidth) return ReplayVerdict::kReplayed;
    const uint64_t bit = uint64_t{1} << age;
    if (seen_ & bit) return ReplayVerdict::kReplayed;
    seen_ |= bit;
    return ReplayVerdict::kReordered;
  }

  uint64_t newest() const { return newest_; }
  void Reset() { newest_ = 0; seen_ = 0; }

 private:
  uint64_t newest_ = 0;
  uint64_t seen_ = 0;  // bit i: newest_ - i was seen
};

}  // namespace hapticd::net
