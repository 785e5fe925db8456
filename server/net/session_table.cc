#include "server/net/session_table.h"

namespace hapticd::net {

bool IsLive(SlotState state) {
  return state == SlotState::kWaiting || state == SlotState::kActive || state == SlotState::kRamping;
}

SessionTable::SessionTable(int capacity) {
  slots_.reserve(capacity);
  for (int i = 0; i < capacity; ++i) slots_.push_back(std::make_unique<SessionSlot>());
}

int SessionTable::FindFree() const {
  for (int i = 0; i < capacity(); ++i) {
    if (slots_[i]->state.load(std::memory_order_acquire) == SlotState::kFree) return i;
  }
  return -1;
}

int SessionTable::FindById(uint32_t id) const {
  for (int i = 0; i < capacity(); ++i) {
    const SessionSlot& slot = *slots_[i];
    if (slot.state.load(std::memory_order_acquire) != SlotState::kFree && slot.id == id) return i;
  }
  return -1;
}

int SessionTable::FindLive(uint32_t id) const {
  for (int i = 0; i < capacity(); ++i) {
    const SessionSlot& slot = *slots_[i];
    if (IsLive(slot.state.load(std::memory_order_acquire)) && slot.id == id) return i;
  }
  return -1;
}

}  // namespace hapticd::net
