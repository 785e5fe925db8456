#pragma once
// The clock of the proxy loop: absolute deadlines on CLOCK_MONOTONIC.
//
// Tick k is due at start_ns + k * period_ns. A loop sleeps until its tick's deadline
// (an absolute sleep, so the time a tick takes never shifts the ticks after it), runs,
// and moves on to the next tick. A loop that fell far behind (a stall of more than
// max_backlog_ticks periods) skips the ticks it missed instead of running them back to
// back, since a burst of stale ticks helps no device.
#include <cstdint>

namespace hapticd::proxy {

// CLOCK_MONOTONIC and CLOCK_REALTIME now, in ns.
int64_t MonotonicNowNs();
int64_t RealtimeNowNs();

// Readies the calling thread for a fixed-rate loop: timer slack of 1 ns (the default 50 us
// would wake every tick up to 50 us late), and SCHED_FIFO at priority when it is > 0.
// Returns whether SCHED_FIFO was granted (it needs CAP_SYS_NICE; the loop runs without).
bool PrepareRealtimeThread(int priority);

// Sleeps until CLOCK_MONOTONIC reads deadline_ns (clock_nanosleep, TIMER_ABSTIME);
// returns at once when it has passed. Resumes after signals.
void SleepUntilNs(int64_t deadline_ns);

// How one tick went, against its deadline and the next.
struct TickTiming {
  int64_t lateness_ns = 0;  // woke - deadline, >= 0 (an early wake counts as on time)
  bool started_late = false;  // lateness over the miss threshold
  bool overran = false;       // the tick's work ended after the next tick's deadline
  bool missed() const { return started_late || overran; }
};

class TickSchedule {
 public:
  // period_ns > 0; max_backlog_ticks >= 1.
  TickSchedule(int64_t start_ns, int64_t period_ns, int max_backlog_ticks)
      : start_ns_(start_ns), period_ns_(period_ns), max_backlog_ticks_(max_backlog_ticks) {}

  int64_t start_ns() const { return start_ns_; }
  int64_t period_ns() const { return period_ns_; }

  // When tick k is due.
  int64_t DeadlineOf(int64_t tick) const { return start_ns_ + tick * period_ns_; }

  // The tick to run after `tick`, now_ns being when it finished: tick + 1, unless now is
  // more than max_backlog_ticks periods past that tick's deadline; then the first tick
  // whose deadline has not passed (the ones between are skipped).
  int64_t NextTick(int64_t tick, int64_t now_ns) const {
    const int64_t next = tick + 1;
    if (now_ns - DeadlineOf(next) <= max_backlog_ticks_ * period_ns_) return next;
    // ceil((now - start) / period): the first deadline at or after now
    return (now_ns - start_ns_ + period_ns_ - 1) / period_ns_;
  }

  // Tick `tick` woke at woke_ns and finished its work at finished_ns: it started late
  // when woke - deadline > miss_threshold_ns, and overran when it finished after the
  // next tick's deadline.
  TickTiming Classify(int64_t tick, int64_t woke_ns, int64_t finished_ns, int64_t miss_threshold_ns) const {
    TickTiming timing;
    const int64_t late_ns = woke_ns - DeadlineOf(tick);
    timing.lateness_ns = late_ns > 0 ? late_ns : 0;
    timing.started_late = timing.lateness_ns > miss_threshold_ns;
    timing.overran = finished_ns > DeadlineOf(tick + 1);
    return timing;
  }

 private:
  int64_t start_ns_;
  int64_t period_ns_;
  int max_backlog_ticks_;
};

}  // namespace hapticd::proxy
