#include "server/net/protobuf_log.h"

#include <google/protobuf/stubs/logging.h>

#include <chrono>
#include <mutex>
#include <string_view>

#include "server/net/log.h"

namespace hapticd::net {
namespace {

// Where this thread's lines go while a capture is alive (its diagnostic), else null.
thread_local std::string* capturing = nullptr;

std::string_view TrimmedRight(std::string_view text) {
  while (!text.empty() && (text.back() == ' ' || text.back() == '\n')) text.remove_suffix(1);
  return text;
}

// protobuf's "String field 'hapticd.v1.Object.name' contains invalid UTF-8 data when
// parsing a protocol buffer. Use the 'bytes' type ..." as "hapticd.v1.Object.name is
// not valid UTF-8"; any other line as it is.
std::string SaidOfTheInput(std::string_view line) {
  constexpr std::string_view kField = "String field '";
  constexpr std::string_view kInvalid = "' contains invalid UTF-8 data";
  if (line.starts_with(kField)) {
    const std::size_t end = line.find(kInvalid, kField.size());
    if (end != std::string_view::npos) {
      return std::string(line.substr(kField.size(), end - kField.size())) + " is not valid UTF-8";
    }
  }
  return std::string(TrimmedRight(line));
}

void HandleProtobufLine(google::protobuf::LogLevel level, const char*, int, const std::string& line) {
  if (level == google::protobuf::LOGLEVEL_FATAL) {
    WriteLogLine(LogLevel::kError, "protobuf: " + std::string(TrimmedRight(line)));
    return;
  }
  if (capturing != nullptr) {
    if (capturing->empty()) *capturing = SaidOfTheInput(line);
    return;
  }
  static std::mutex mutex;
  static LogLimiter limiter(5, std::chrono::seconds(10));
  const std::lock_guard lock(mutex);
  limiter.Log(level == google::protobuf::LOGLEVEL_INFO ? LogLevel::kDebug : LogLevel::kWarning, "protobuf: {}",
              TrimmedRight(line));
}

}  // namespace

void RouteProtobufLog() {
  static std::once_flag once;
  std::call_once(once, [] { google::protobuf::SetLogHandler(&HandleProtobufLine); });
}

ProtobufLogCapture::ProtobufLogCapture() : outer_(capturing) { capturing = &diagnostic_; }

ProtobufLogCapture::~ProtobufLogCapture() { capturing = outer_; }

}  // namespace hapticd::net
