#include "clients/cpp/tick_schedule.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <cerrno>
#include <ctime>

namespace hapticd::proxy {
namespace {

constexpr int64_t kNsPerSecond = 1'000'000'000;

int64_t NowNs(clockid_t clock) {
  timespec now;
  clock_gettime(clock, &now);
  return int64_t{now.tv_sec} * kNsPerSecond + now.tv_nsec;
}

}  // namespace

int64_t MonotonicNowNs() { return NowNs(CLOCK_MONOTONIC); }

int64_t RealtimeNowNs() { return NowNs(CLOCK_REALTIME); }

bool PrepareRealtimeThread(int priority) {
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (priority <= 0) return false;
  sched_param parameters{};
  parameters.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &parameters) == 0;
}

void SleepUntilNs(int64_t deadline_ns) {
  const timespec deadline{static_cast<time_t>(deadline_ns / kNsPerSecond),
                          static_cast<long>(deadline_ns % kNsPerSecond)};
  // an absolute sleep resumes cleanly after a signal: the deadline does not move
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
  }
}

}  // namespace hapticd::proxy
