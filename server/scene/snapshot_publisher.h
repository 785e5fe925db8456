#pragma once

// Publishes scene snapshots to real-time readers without a lock on their side.
//
// Theory of operation (read-copy-update with per-reader epochs):
//   writer (control thread)                 reader k (a 1 kHz tick)
//   ---------------------------             -------------------------------------
//   build next snapshot                     Acquire(k): slot k = 1 (pins every
//   Publish(next): swap current,              version), load current, narrow slot k
//     retire the old one                      to its version
//   reclaim retired snapshots older         ... use the snapshot for the whole tick ...
//     than every busy slot's version        Release(k): slot k = idle
// A retired snapshot is freed only when no reader slot can still hold it, so readers
// never see a freed snapshot, never block and never free anything (the writer does).

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "server/scene/scene_snapshot.h"

namespace hapticd::scene {

class SnapshotPublisher {
 public:
  // max_readers: reader slots (one per real-time thread or session), fixed up front.
  SnapshotPublisher(std::shared_ptr<const SceneSnapshot> initial, int max_readers);
  ~SnapshotPublisher();
  SnapshotPublisher(const SnapshotPublisher&) = delete;
  SnapshotPublisher& operator=(const SnapshotPublisher&) = delete;

  // Off the real-time path: a free reader slot, or -1 when all are taken.
  int AddReader();
  void RemoveReader(int reader);

  // Real-time: the current snapshot, valid until Release(reader). Lock-free, no
  // allocation. Acquire twice without Release is a precondition violation.
  const SceneSnapshot& Acquire(int reader);
  void Release(int reader);

  // Off the real-time path: make next current (its version must exceed the current
  // one's; throws std::invalid_argument otherwise) and free retired snapshots no
  // reader holds.
  void Publish(std::shared_ptr<const SceneSnapshot> next);
  // Off the real-time path: the current snapshot, shared.
  std::shared_ptr<const SceneSnapshot> current() const;
  // Retired snapshots not yet freed (for tests and telemetry).
  int num_retired() const;

 private:
  void ReclaimLocked();

  static constexpr uint64_t kIdle = 0;
  static constexpr uint64_t kFree = ~uint64_t{0};
  struct alignas(64) ReaderSlot {
    std::atomic<uint64_t> version{kFree};  // kFree: unused; kIdle: not in a tick
  };

  std::atomic<const SceneSnapshot*> current_;
  std::vector<ReaderSlot> slots_;
  mutable std::mutex writer_mutex_;  // writers and slot bookkeeping only; never readers
  std::shared_ptr<const SceneSnapshot> current_owner_;
  std::vector<std::shared_ptr<const SceneSnapshot>> retired_;
};

}  // namespace hapticd::scene
