#pragma once
// Leveled logging to stderr, one line per event ("2026-11-25T03:40:01.123Z info session
// 1a2b3c4d opened ..."). For the control and start-up threads only: the realtime thread
// never logs; its events are counted and reported from the control thread.
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>
#include <fmt/format.h>

namespace hapticd::net {

enum class LogLevel { kDebug, kInfo, kWarning, kError, kCount };

// "debug", "info", "warning", "error"; nullopt-like kCount for an unknown name.
LogLevel ParseLogLevel(std::string_view name);
std::string_view LogLevelName(LogLevel level);

// Lines below this level are dropped. Set once at start-up.
void SetLogLevel(LogLevel level);
bool LogEnabled(LogLevel level);
void WriteLogLine(LogLevel level, std::string_view message);

template <typename... Args>
void Log(LogLevel level, fmt::format_string<Args...> format, Args&&... args) {
  if (LogEnabled(level)) WriteLogLine(level, fmt::format(format, std::forward<Args>(args)...));
}

// For lines a peer can provoke at will (failed handshakes, refused connections, accept
// errors): at most `burst` lines per `interval`; the first line let through after a
// quiet spell says how many were held back.
class LogLimiter {
 public:
  using Clock = std::chrono::steady_clock;
  LogLimiter(int burst, Clock::duration interval) : burst_(burst), interval_(interval) {}

  template <typename... Args>
  void Log(LogLevel level, fmt::format_string<Args...> format, Args&&... args) {
    if (!LogEnabled(level)) return;
    const Clock::time_point now = Clock::now();
    if (now - window_start_ >= interval_) {
      window_start_ = now;
      written_ = 0;
    }
    if (written_ >= burst_) {
      ++suppressed_;
      return;
    }
    ++written_;
    std::string line = fmt::format(format, std::forward<Args>(args)...);
    if (suppressed_ > 0) line += fmt::format(" ({} similar lines suppressed)", suppressed_);
    suppressed_ = 0;
    WriteLogLine(level, line);
  }
  uint64_t suppressed() const { return suppressed_; }

 private:
  int burst_;
  Clock::duration interval_;
  Clock::time_point window_start_{};
  int written_ = 0;
  uint64_t suppressed_ = 0;
};

}  // namespace hapticd::net
