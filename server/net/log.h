#pragma once
// Leveled logging to stderr, one line per event ("2026-11-25T03:40:01.123Z info session
// 1a2b3c4d opened ..."). For the control and start-up threads only: the realtime thread
// never logs; its events are counted and reported from the control thread.
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

}  // namespace hapticd::net
