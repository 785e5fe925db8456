#pragma once
// protobuf's own log lines, routed into hapticd's log. protobuf writes a line to stderr
// when a parse meets a string field that is not UTF-8 (it refuses the message too); a
// control client can provoke that with every frame it sends, and the lines would pass
// by hapticd's log format, level and rate limits (2,000 bad frames: 426 kB of stderr).
// Once RouteProtobufLog() has run:
//  - on a thread inside a ProtobufLogCapture, a line goes to the capture, so that the
//    parse that provoked it can say in its error reply what was wrong;
//  - elsewhere, to hapticd's log as a warning ("protobuf: ..."), at most 5 lines in
//    10 s (the first one after a quiet spell counts those held back);
//  - a fatal line is always logged (protobuf ends the process after it).
// For the control and start-up threads: the realtime thread never calls protobuf.
#include <string>

namespace hapticd::net {

// Installs the routing for the whole process. Call it at start-up, before other threads
// run (protobuf's SetLogHandler is not thread-safe); later calls do nothing.
void RouteProtobufLog();

// While alive, takes this thread's protobuf log lines (nested captures: the innermost).
class ProtobufLogCapture {
 public:
  ProtobufLogCapture();
  ~ProtobufLogCapture();
  ProtobufLogCapture(const ProtobufLogCapture&) = delete;
  ProtobufLogCapture& operator=(const ProtobufLogCapture&) = delete;

  // The first line protobuf logged meanwhile, said of the input: "hapticd.v1.Object.name
  // is not valid UTF-8" for its invalid-UTF-8 line, any other line as it is; empty when
  // it logged nothing (or the routing is not installed).
  const std::string& diagnostic() const { return diagnostic_; }

 private:
  std::string diagnostic_;
  std::string* outer_;
};

}  // namespace hapticd::net
