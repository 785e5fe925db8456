#include "server/net/protobuf_log.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <thread>

#include "hapticd/v1/hapticd.pb.h"

namespace hapticd::net {
namespace {

// A request whose object's name is not UTF-8 (0xff never occurs in UTF-8): protobuf
// refuses it, and says so in a log line.
std::string RequestWithLatin1Name() {
  v1::Request request;
  request.set_request_id(7);
  request.mutable_add_object()->mutable_object()->set_name("AAAA");
  std::string bytes = request.SerializeAsString();
  bytes.replace(bytes.find("AAAA"), 4, "caf\xe9");
  return bytes;
}

bool Parses(const std::string& bytes) {
  v1::Request request;
  return request.ParseFromString(bytes);
}

class ProtobufLogTest : public testing::Test {
 protected:
  static void SetUpTestSuite() { RouteProtobufLog(); }
};

TEST_F(ProtobufLogTest, ACaptureTakesTheLineAndSaysWhatWasWrong) {
  testing::internal::CaptureStderr();
  std::string diagnostic;
  {
    const ProtobufLogCapture capture;
    EXPECT_FALSE(Parses(RequestWithLatin1Name()));
    // the first line is kept
    EXPECT_FALSE(Parses(RequestWithLatin1Name()));
    diagnostic = capture.diagnostic();
  }
  EXPECT_EQ(diagnostic, "hapticd.v1.Object.name is not valid UTF-8");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  // nothing said: nothing captured
  const ProtobufLogCapture quiet;
  EXPECT_TRUE(Parses(v1::Request().SerializeAsString()));
  EXPECT_EQ(quiet.diagnostic(), "");
}

TEST_F(ProtobufLogTest, TheInnermostCaptureTakesTheLine) {
  const ProtobufLogCapture outer;
  {
    const ProtobufLogCapture inner;
    EXPECT_FALSE(Parses(RequestWithLatin1Name()));
    EXPECT_EQ(inner.diagnostic(), "hapticd.v1.Object.name is not valid UTF-8");
  }
  EXPECT_EQ(outer.diagnostic(), "");
  EXPECT_FALSE(Parses(RequestWithLatin1Name()));
  EXPECT_EQ(outer.diagnostic(), "hapticd.v1.Object.name is not valid UTF-8");
}

// A capture is its own thread's: another thread's line goes to the log.
TEST_F(ProtobufLogTest, ACaptureTakesOnlyItsOwnThreadsLines) {
  const ProtobufLogCapture capture;
  testing::internal::CaptureStderr();
  std::thread([] { EXPECT_FALSE(Parses(RequestWithLatin1Name())); }).join();
  const std::string logged = testing::internal::GetCapturedStderr();
  EXPECT_EQ(capture.diagnostic(), "");
  EXPECT_NE(logged.find(" warning protobuf: String field 'hapticd.v1.Object.name' contains invalid UTF-8 data"),
            std::string::npos)
      << logged;
}

// Outside a capture the lines are hapticd's log lines, a few per 10 s however many
// bad messages come (the thread test above may have written one of this window's).
TEST_F(ProtobufLogTest, UncapturedLinesAreLoggedAtABoundedRate) {
  testing::internal::CaptureStderr();
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(Parses(RequestWithLatin1Name()));
  std::istringstream logged(testing::internal::GetCapturedStderr());
  int lines = 0;
  for (std::string line; std::getline(logged, line);) {
    ++lines;
    EXPECT_NE(line.find(" warning protobuf: String field 'hapticd.v1.Object.name'"), std::string::npos) << line;
    EXPECT_EQ(line.find("[libprotobuf"), std::string::npos) << line;
  }
  EXPECT_GE(lines, 1);
  EXPECT_LE(lines, 5);
}

}  // namespace
}  // namespace hapticd::net
