#include "server/net/replay_window.h"

#include <random>
#include <set>

#include <gtest/gtest.h>

namespace hapticd::net {
namespace {

TEST(ReplayWindow, AcceptsOnlyNewerSequences) {
  ReplayWindow window;
  EXPECT_EQ(window.Check(1), ReplayVerdict::kFresh);
  EXPECT_EQ(window.Check(2), ReplayVerdict::kFresh);
  EXPECT_EQ(window.Check(2), ReplayVerdict::kReplayed);
  EXPECT_EQ(window.Check(5), ReplayVerdict::kFresh);
  // 3 and 4 never came: late, not replays; the second time they are replays.
  EXPECT_EQ(window.Check(4), ReplayVerdict::kReordered);
  EXPECT_EQ(window.Check(4), ReplayVerdict::kReplayed);
  EXPECT_EQ(window.Check(3), ReplayVerdict::kReordered);
  EXPECT_EQ(window.Check(1), ReplayVerdict::kReplayed);
  EXPECT_EQ(window.newest(), 5u);
}

TEST(ReplayWindow, ZeroAndOlderThanTheWindowAreReplays) {
  ReplayWindow window;
  EXPECT_EQ(window.Check(0), ReplayVerdict::kReplayed);
  EXPECT_EQ(window.Check(1000), ReplayVerdict::kFresh);
  EXPECT_EQ(window.Check(1000 - ReplayWindow::kWidth + 1), ReplayVerdict::kReordered);
  EXPECT_EQ(window.Check(1000 - ReplayWindow::kWidth), ReplayVerdict::kReplayed);
  // A jump wider than the window forgets everything before it.
  EXPECT_EQ(window.Check(5000), ReplayVerdict::kFresh);
  EXPECT_EQ(window.Check(4999), ReplayVerdict::kReordered);
  EXPECT_EQ(window.Check(UINT64_MAX), ReplayVerdict::kFresh);
  EXPECT_EQ(window.Check(UINT64_MAX), ReplayVerdict::kReplayed);
}

// Against an oracle that remembers every sequence: the window must agree on every
// arrival within its width, and call everything older a replay.
TEST(ReplayWindow, AgreesWithAFullHistoryOracle) {
  std::mt19937_64 random(7);
  ReplayWindow window;
  std::set<uint64_t> seen;
  uint64_t newest = 0;
  for (int i = 0; i < 100000; ++i) {
    // Mostly forward, with duplicates, late arrivals and jumps.
    const int64_t step = std::uniform_int_distribution<int64_t>(-80, 3)(random);
    const uint64_t sequence = static_cast<uint64_t>(std::max<int64_t>(1, static_cast<int64_t>(newest) + step));
    ReplayVerdict expected;
    if (sequence > newest) {
      expected = ReplayVerdict::kFresh;
    } else if (newest - sequence >= ReplayWindow::kWidth || seen.count(sequence)) {
      expected = ReplayVerdict::kReplayed;
    } else {
      expected = ReplayVerdict::kReordered;
    }
    ASSERT_EQ(window.Check(sequence), expected) << "arrival " << i << " sequence " << sequence;
    seen.insert(sequence);
    newest = std::max(newest, sequence);
  }
}

}  // namespace
}  // namespace hapticd::net
