#include "clients/cpp/tick_schedule.h"

#include <gtest/gtest.h>

namespace hapticd::proxy {
namespace {

constexpr int64_t kStart = 5'000'000'000;  // ns
constexpr int64_t kPeriod = 1'000'000;     // 1 kHz

TEST(TickSchedule, DeadlinesAreAbsolute) {
  const TickSchedule schedule(kStart, kPeriod, 10);
  EXPECT_EQ(schedule.DeadlineOf(0), kStart);
  EXPECT_EQ(schedule.DeadlineOf(1), kStart + kPeriod);
  // tick k does not depend on how long the ticks before it took
  EXPECT_EQ(schedule.DeadlineOf(123'456), kStart + 123'456 * kPeriod);
}

TEST(TickSchedule, ALateTickDoesNotShiftTheNext) {
  const TickSchedule schedule(kStart, kPeriod, 10);
  // tick 3 finished 0.9 periods after tick 4 was due: tick 4 still runs, at once
  EXPECT_EQ(schedule.NextTick(3, schedule.DeadlineOf(4) + 900'000), 4);
  // exactly max_backlog periods behind is still caught up tick by tick
  EXPECT_EQ(schedule.NextTick(3, schedule.DeadlineOf(4) + 10 * kPeriod), 4);
}

TEST(TickSchedule, AStallSkipsToThePresent) {
  const TickSchedule schedule(kStart, kPeriod, 10);
  // 50.5 periods past tick 4's deadline: the first deadline not yet past is tick 55's
  const int64_t now = schedule.DeadlineOf(4) + 50 * kPeriod + kPeriod / 2;
  const int64_t next = schedule.NextTick(3, now);
  EXPECT_EQ(next, 55);
  EXPECT_GE(schedule.DeadlineOf(next), now);
  EXPECT_LT(schedule.DeadlineOf(next - 1), now);
  // landing exactly on a deadline runs that tick
  EXPECT_EQ(schedule.NextTick(3, schedule.DeadlineOf(40)), 40);
}

TEST(TickSchedule, ClassifiesLatenessAndOverruns) {
  const TickSchedule schedule(kStart, kPeriod, 10);
  const int64_t threshold = 100'000;
  // on time, work within the period
  TickTiming t = schedule.Classify(7, schedule.DeadlineOf(7) + 20'000, schedule.DeadlineOf(7) + 400'000, threshold);
  EXPECT_EQ(t.lateness_ns, 20'000);
  EXPECT_FALSE(t.missed());
  // an early wake counts as on time
  t = schedule.Classify(7, schedule.DeadlineOf(7) - 5'000, schedule.DeadlineOf(7), threshold);
  EXPECT_EQ(t.lateness_ns, 0);
  // at the threshold is on time, past it is late
  EXPECT_FALSE(schedule.Classify(7, schedule.DeadlineOf(7) + threshold, schedule.DeadlineOf(7) + threshold, threshold)
                   .started_late);
  t = schedule.Classify(7, schedule.DeadlineOf(7) + threshold + 1, schedule.DeadlineOf(7) + threshold + 1, threshold);
  EXPECT_TRUE(t.started_late);
  EXPECT_FALSE(t.overran);
  EXPECT_TRUE(t.missed());
  // finishing at the next deadline is fine, after it is an overrun
  EXPECT_FALSE(schedule.Classify(7, schedule.DeadlineOf(7), schedule.DeadlineOf(8), threshold).overran);
  t = schedule.Classify(7, schedule.DeadlineOf(7), schedule.DeadlineOf(8) + 1, threshold);
  EXPECT_TRUE(t.overran);
  EXPECT_FALSE(t.started_late);
  EXPECT_TRUE(t.missed());
}

// The sleep never returns before its deadline, and a past deadline returns at once.
TEST(TickSchedule, SleepUntilIsAbsolute) {
  const int64_t deadline = MonotonicNowNs() + 2'000'000;
  SleepUntilNs(deadline);
  EXPECT_GE(MonotonicNowNs(), deadline);
  const int64_t before = MonotonicNowNs();
  SleepUntilNs(before - 1'000'000'000);
  EXPECT_GE(MonotonicNowNs(), before);
}

}  // namespace
}  // namespace hapticd::proxy
