#include "server/net/log.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>

namespace hapticd::net {
namespace {

constexpr std::string_view kNames[] = {"debug", "info", "warning", "error"};

// The logger is process-wide like stderr itself: one level, one lock around the write.
std::atomic<LogLevel> g_level{LogLevel::kInfo};
std::mutex g_write_mutex;

}  // namespace

LogLevel ParseLogLevel(std::string_view name) {
  for (int i = 0; i < static_cast<int>(LogLevel::kCount); ++i) {
    if (kNames[i] == name) return static_cast<LogLevel>(i);
  }
  return LogLevel::kCount;
}

std::string_view LogLevelName(LogLevel level) {
  const int i = static_cast<int>(level);
  return i >= 0 && i < static_cast<int>(LogLevel::kCount) ? kNames[i] : "unknown";
}

void SetLogLevel(LogLevel level) { g_level.store(level); }

bool LogEnabled(LogLevel level) { return level >= g_level.load(std::memory_order_relaxed); }

void WriteLogLine(LogLevel level, std::string_view message) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc;
  gmtime_r(&seconds, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &utc);
  const std::lock_guard lock(g_write_mutex);
  std::fprintf(stderr, "%s.%03dZ %s %.*s\n", stamp, static_cast<int>(ms), kNames[static_cast<int>(level)].data(),
               static_cast<int>(message.size()), message.data());
  std::fflush(stderr);
}

}  // namespace hapticd::net
