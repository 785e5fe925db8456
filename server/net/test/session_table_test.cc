#include "server/net/session_table.h"

#include <set>

#include <gtest/gtest.h>

namespace hapticd::net {
namespace {

TEST(SessionTable, IdsCarryTheirSlotAndAreFoundOnlyWhileLive) {
  SessionTable table(5);
  std::set<uint32_t> ids;
  for (int i = 0; i < 1000; ++i) {
    const uint32_t id = table.MakeId(3);
    EXPECT_NE(id, 0u);
    EXPECT_EQ(static_cast<int>(id & (kMaxSessions - 1)), 3);
    ids.insert(id);
  }
  EXPECT_GT(ids.size(), 990u);  // 20 random bits: a repeat in 1000 draws is rare

  SessionSlot& slot = table.slot(3);
  slot.id = *ids.begin();
  EXPECT_EQ(table.FindLive(slot.id), -1);  // still free
  EXPECT_EQ(table.FindById(slot.id), -1);
  for (SlotState live : {SlotState::kWaiting, SlotState::kActive, SlotState::kRamping}) {
    slot.state.store(live);
    EXPECT_EQ(table.FindLive(slot.id), 3);
    EXPECT_EQ(table.FindById(slot.id), 3);
  }
  // Another id on the same slot, or an index past the table, finds nothing.
  EXPECT_EQ(table.FindLive(slot.id ^ 0x10000), -1);
  EXPECT_EQ(table.FindLive((slot.id & ~uint32_t{kMaxSessions - 1}) | 7u), -1);
  // Handed back: not live, but still the control thread's until reclaimed.
  slot.state.store(SlotState::kTimedOut);
  EXPECT_EQ(table.FindLive(slot.id), -1);
  EXPECT_EQ(table.FindById(slot.id), 3);
  // A new id never repeats one still in the table.
  for (int i = 0; i < 1000; ++i) EXPECT_NE(table.MakeId(3), slot.id);
  EXPECT_EQ(table.FindFree(), 0);
  // Scans stop past the highest slot ever opened.
  EXPECT_EQ(table.used_slots(), 0);
  table.MarkOpened(3);
  table.MarkOpened(1);
  EXPECT_EQ(table.used_slots(), 4);
}

TEST(SessionTable, RefusesCapacitiesOutsideTheIdSpace) {
  EXPECT_THROW(SessionTable(0), std::invalid_argument);
  EXPECT_THROW(SessionTable(kMaxSessions + 1), std::invalid_argument);
  EXPECT_EQ(SessionTable(kMaxSessions).capacity(), kMaxSessions);
}

}  // namespace
}  // namespace hapticd::net
