#pragma once
// Hands a session's newest encoded local model from the model thread (model_feed.h) to
// the realtime thread without a lock: a triple buffer. The writer fills its back buffer
// and swaps it with the middle one, marked fresh; the reader swaps a fresh middle buffer
// with its front one. Each side owns its buffer between swaps, so neither waits, and the
// reader always holds the newest complete model. Preallocated (3 x kMaxModelBytes).
#include <array>
#include <atomic>
#include <cstdint>

#include "server/net/datagram_codec.h"

namespace hapticd::net {

struct EncodedModel {
  uint32_t session_id = 0;  // whose: a slot's next session must not send its last one's
  uint64_t version = 0;     // 0: none
  std::size_t size = 0;
  std::array<uint8_t, kMaxModelBytes> bytes;
};

class ModelMailbox {
 public:
  // Writer: the buffer to fill, then Publish it.
  EncodedModel& back() { return buffers_[back_]; }
  void Publish() { back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex; }
  // Reader: the newest model published (version 0 before any). Real-time safe.
  const EncodedModel& Newest() {
    if (middle_.load(std::memory_order_relaxed) & kFresh) {
      front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    }
    return buffers_[front_];
  }

 private:
  static constexpr uint8_t kIndex = 3, kFresh = 4;
  std::array<EncodedModel, 3> buffers_{};
  uint8_t back_ = 0;   // the writer's
  uint8_t front_ = 1;  // the reader's
  std::atomic<uint8_t> middle_{2};
};

}  // namespace hapticd::net
