#include "server/net/session_table.h"

#include <sodium.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <stdexcept>
#include <system_error>

namespace hapticd::net {

bool IsLive(SlotState state) {
  return state == SlotState::kWaiting || state == SlotState::kActive || state == SlotState::kRamping;
}

SessionTable::SessionTable(int capacity) {
  if (capacity < 1 || capacity > kMaxSessions) {
    throw std::invalid_argument("a session table holds 1 to " + std::to_string(kMaxSessions) + " sessions, not " +
                                std::to_string(capacity));
  }
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
  slots_.reserve(capacity);
  for (int i = 0; i < capacity; ++i) slots_.push_back(std::make_unique<SessionSlot>());
  doorbell_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (doorbell_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd for the session table");
}

SessionTable::~SessionTable() { ::close(doorbell_fd_); }

void SessionTable::Ring() {
  const uint64_t one = 1;
  // a full counter (2^64 - 2 rings unanswered) is still readable: nothing is lost
  [[maybe_unused]] const ssize_t written = ::write(doorbell_fd_, &one, sizeof one);
}

void SessionTable::Answer() {
  uint64_t rings = 0;
  [[maybe_unused]] const ssize_t read = ::read(doorbell_fd_, &rings, sizeof rings);
}

int SessionTable::FindFree() const {
  for (int i = 0; i < capacity(); ++i) {
    if (slots_[i]->state.load(std::memory_order_acquire) == SlotState::kFree) return i;
  }
  return -1;
}

void SessionTable::MarkOpened(int index) {
  if (index >= used_slots_.load(std::memory_order_relaxed)) used_slots_.store(index + 1, std::memory_order_release);
}

int SessionTable::FindById(uint32_t id) const {
  for (int i = 0; i < capacity(); ++i) {
    const SessionSlot& slot = *slots_[i];
    if (slot.state.load(std::memory_order_acquire) != SlotState::kFree && slot.id == id) return i;
  }
  return -1;
}

int SessionTable::FindLive(uint32_t id) const {
  const int index = static_cast<int>(id & (kMaxSessions - 1));
  if (index >= capacity()) return -1;
  const SessionSlot& slot = *slots_[index];
  return IsLive(slot.state.load(std::memory_order_acquire)) && slot.id == id ? index : -1;
}

uint32_t SessionTable::MakeId(int index) const {
  uint32_t id = 0;
  while (id == 0 || FindById(id) >= 0) {
    id = (randombytes_random() & ~static_cast<uint32_t>(kMaxSessions - 1)) | static_cast<uint32_t>(index);
  }
  return id;
}

}  // namespace hapticd::net
