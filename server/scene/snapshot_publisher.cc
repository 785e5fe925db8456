#include "server/scene/snapshot_publisher.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace hapticd::scene {
namespace {

// A slot value that pins every snapshot (versions start at 1, and only versions below
// the smallest busy slot are freed): what a reader holds while it has loaded current_
// but not yet read that snapshot's version.
constexpr uint64_t kPinAll = 1;

}  // namespace

SnapshotPublisher::SnapshotPublisher(std::shared_ptr<const SceneSnapshot> initial,
                                     int max_readers)
    : slots_(static_cast<size_t>(std::max(max_readers, 0))) {
  if (!initial) throw std::invalid_argument("SnapshotPublisher needs an initial snapshot");
  if (max_readers < 0) {
    throw std::invalid_argument("max_readers is " + std::to_string(max_readers) +
                                "; it must be >= 0");
  }
  // version 0 would read as an idle slot, ~0 as a free one
  if (initial->version() == kIdle || initial->version() == kFree) {
    throw std::invalid_argument("the initial snapshot's version is " +
                                std::to_string(initial->version()) +
                                "; versions start at 1");
  }
  current_.store(initial.get(), std::memory_order_seq_cst);
  current_owner_ = std::move(initial);
}

// Readers must have released their slots: the snapshots go with the publisher.
SnapshotPublisher::~SnapshotPublisher() = default;

int SnapshotPublisher::AddReader() {
  std::lock_guard<std::mutex> lock(writer_mutex_);
  for (size_t k = 0; k < slots_.size(); ++k) {
    if (slots_[k].version.load(std::memory_order_relaxed) == kFree) {
      slots_[k].version.store(kIdle, std::memory_order_seq_cst);
      return static_cast<int>(k);
    }
  }
  // every slot taken: the caller degrades (no new reader), nothing grows
  return -1;
}

void SnapshotPublisher::RemoveReader(int reader) {
  std::lock_guard<std::mutex> lock(writer_mutex_);
  if (reader < 0 || reader >= static_cast<int>(slots_.size())) {
    throw std::invalid_argument("reader " + std::to_string(reader) + " does not exist (" +
                                std::to_string(slots_.size()) + " slots)");
  }
  slots_[reader].version.store(kFree, std::memory_order_seq_cst);
  // what that reader held may be freeable now
  ReclaimLocked();
}

// Pin everything, load current_, then narrow the pin to that snapshot's version. The
// pin is published (seq_cst) before current_ is loaded, so a writer that swaps
// current_ and then scans the slots either sees the pin, or swapped before this load
// and so cannot be retiring what it returns. The snapshot's version is read only once
// it is pinned: reading it first could touch a snapshot freed meanwhile.
const SceneSnapshot& SnapshotPublisher::Acquire(int reader) {
  std::atomic<uint64_t>& slot = slots_[reader].version;
  slot.store(kPinAll, std::memory_order_seq_cst);
  const SceneSnapshot* snapshot = current_.load(std::memory_order_seq_cst);
  slot.store(snapshot->version(), std::memory_order_seq_cst);
  return *snapshot;
}

// Release ordering: the tick's reads of the snapshot happen before a writer that sees
// the slot idle frees it.
void SnapshotPublisher::Release(int reader) {
  slots_[reader].version.store(kIdle, std::memory_order_release);
}

void SnapshotPublisher::Publish(std::shared_ptr<const SceneSnapshot> next) {
  if (!next) throw std::invalid_argument("cannot publish a null snapshot");
  std::lock_guard<std::mutex> lock(writer_mutex_);
  // versions only grow: readers' pins compare them
  if (next->version() <= current_owner_->version() || next->version() == kFree) {
    throw std::invalid_argument("snapshot version " + std::to_string(next->version()) +
                                " must exceed the current version " +
                                std::to_string(current_owner_->version()));
  }
  current_.store(next.get(), std::memory_order_seq_cst);
  retired_.push_back(std::exchange(current_owner_, std::move(next)));
  ReclaimLocked();
}

std::shared_ptr<const SceneSnapshot> SnapshotPublisher::current() const {
  std::lock_guard<std::mutex> lock(writer_mutex_);
  return current_owner_;
}

int SnapshotPublisher::num_retired() const {
  std::lock_guard<std::mutex> lock(writer_mutex_);
  return static_cast<int>(retired_.size());
}

// A busy slot holds the version of the snapshot its reader uses (or kPinAll), and
// every snapshot a reader can reach has at least that version; retired snapshots below
// the smallest busy version are unreachable.
void SnapshotPublisher::ReclaimLocked() {
  uint64_t oldest_in_use = std::numeric_limits<uint64_t>::max();
  for (const ReaderSlot& slot : slots_) {
    const uint64_t v = slot.version.load(std::memory_order_seq_cst);
    if (v != kIdle && v != kFree) oldest_in_use = std::min(oldest_in_use, v);
  }
  std::erase_if(retired_, [&](const std::shared_ptr<const SceneSnapshot>& s) {
    return s->version() < oldest_in_use;
  });
}

}  // namespace hapticd::scene
