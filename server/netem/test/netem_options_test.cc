// hapticd-netem's flags: both directions and one, whatever the order; every bad value
// refused with a message naming the flag; delay traces read with their header, comments
// and errors by line.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "server/netem/netem_options.h"

namespace hapticd::netem {
namespace {

NetemOptions Parse(std::vector<std::string> args) {
  args.insert(args.begin(), {"--listen", "127.0.0.1:0", "--forward", "127.0.0.1:7461"});
  std::vector<std::string_view> views(args.begin(), args.end());
  return ParseNetemOptions(views);
}

std::string ErrorOf(std::vector<std::string> args) {
  try {
    Parse(std::move(args));
  } catch (const OptionsError& error) {
    return error.what();
  }
  return "";
}

TEST(NetemOptions, BothDirectionsAndOneWhateverTheOrder) {
  const NetemOptions o = Parse({"--up-delay-ms", "30", "--delay-ms", "20", "--jitter-ms", "2", "--down-loss", "5%",
                                "--loss", "0.01", "--seed", "42"});
  EXPECT_EQ(o.up.delay_ms, 30);
  EXPECT_EQ(o.down.delay_ms, 20);
  EXPECT_EQ(o.up.jitter_ms, 2);
  EXPECT_EQ(o.down.jitter_ms, 2);
  EXPECT_DOUBLE_EQ(o.up.loss, 0.01);
  EXPECT_DOUBLE_EQ(o.down.loss, 0.05);
  EXPECT_EQ(o.seed, 42u);
  EXPECT_EQ(o.listen.port, 0);
  EXPECT_EQ(o.forward.port, 7461);
}

TEST(NetemOptions, EveryImpairment) {
  const NetemOptions o = Parse({"--jitter-distribution", "normal", "--loss-burst", "0.02,0.25,0.9,0.01", "--reorder",
                                "10%", "--duplicate", "0.5", "--rate-kbit", "800", "--queue-limit", "50",
                                "--max-flows", "3", "--flow-idle-s", "0.5", "--realtime-priority", "0",
                                "--duration-s", "2", "--spin-us", "100"});
  EXPECT_EQ(o.down.jitter_distribution, JitterDistribution::kNormal);
  EXPECT_TRUE(o.up.bursty);
  EXPECT_DOUBLE_EQ(o.up.burst.p, 0.02);
  EXPECT_DOUBLE_EQ(o.up.burst.r, 0.25);
  EXPECT_DOUBLE_EQ(o.up.burst.loss_bad, 0.9);
  EXPECT_DOUBLE_EQ(o.up.burst.loss_good, 0.01);
  EXPECT_DOUBLE_EQ(o.down.reorder, 0.1);
  EXPECT_DOUBLE_EQ(o.up.duplicate, 0.5);
  EXPECT_DOUBLE_EQ(o.up.rate_bytes_per_s, 100'000);
  EXPECT_EQ(o.queue_limit, 50);
  EXPECT_EQ(o.max_flows, 3);
  EXPECT_EQ(o.flow_idle_s, 0.5);
  EXPECT_EQ(o.realtime_priority, 0);
  EXPECT_EQ(o.duration_s, 2);
  EXPECT_EQ(o.spin_us, 100);
}

TEST(NetemOptions, BadValuesNameTheirFlag) {
  const std::pair<std::vector<std::string>, std::string> cases[] = {
      {{"--delay-ms", "-1"}, "--delay-ms is \"-1\""},
      {{"--up-delay-ms", "abc"}, "--up-delay-ms is \"abc\""},
      {{"--delay-ms", "70000"}, "--delay-ms is \"70000\""},
      {{"--jitter-ms", "nan"}, "--jitter-ms is \"nan\""},
      {{"--loss", "1.5"}, "--loss is \"1.5\""},
      {{"--down-loss", "101%"}, "--down-loss is \"101\""},
      {{"--loss-burst", "0.1"}, "--loss-burst is \"0.1\""},
      {{"--loss-burst", "0.1,0"}, "R must be above 0"},
      {{"--jitter-distribution", "pareto"}, "--jitter-distribution is \"pareto\""},
      {{"--rate-kbit", "0"}, "--rate-kbit is \"0\""},
      {{"--queue-limit", "0"}, "--queue-limit is \"0\""},
      {{"--max-flows", "5000"}, "--max-flows is \"5000\""},
      {{"--seed", "-3"}, "--seed is \"-3\""},
      {{"--spin-us", "5000"}, "--spin-us is \"5000\""},
      {{"--delay-trace", "/nonexistent/trace.csv"}, "--delay-trace is \"/nonexistent/trace.csv\""},
      {{"--bogus", "1"}, "unknown option \"--bogus\""},
      {{"--sideways-delay-ms", "1"}, "unknown option \"--sideways-delay-ms\""},
      {{"--delay-ms"}, "--delay-ms needs a value"},
      {{"stray"}, "unexpected argument \"stray\""},
  };
  for (const auto& [args, want] : cases) {
    const std::string error = ErrorOf(args);
    EXPECT_NE(error.find(want), std::string::npos) << args[0] << ": " << error;
  }
  EXPECT_NE(ErrorOf({"--listen", "no_such host:9"}).find("--listen is \"no_such host:9\""), std::string::npos);
  EXPECT_NE(ErrorOf({"--listen", "::1:9"}).find("neither an IPv4 address nor a host name"), std::string::npos);
  EXPECT_EQ(Parse({"--forward", "server.lab:7461"}).forward.host, "server.lab");  // a name, resolved at start
  EXPECT_NE(ErrorOf({"--forward", "127.0.0.1"}).find("--forward is \"127.0.0.1\""), std::string::npos);
  EXPECT_NE(ErrorOf({"--forward", "127.0.0.1:0"}).find("--forward's port is 0"), std::string::npos);
  const std::vector<std::string_view> none;
  EXPECT_THROW(ParseNetemOptions(none), OptionsError);  // no --listen
}

TEST(NetemOptions, DelayTracesSkipTheirHeaderAndCommentsAndNameABadLine) {
  const std::string path = testing::TempDir() + "trace.csv";
  std::ofstream(path) << "delay_ms,note\n# recorded\n3.5,a\n\n0\n 12 \n";
  const NetemOptions o = Parse({"--down-delay-trace", path});
  EXPECT_EQ(o.down.delay_trace_ms, (std::vector<double>{3.5, 0, 12}));
  EXPECT_TRUE(o.up.delay_trace_ms.empty());
  std::ofstream(path) << "1\n2\nlate\n";
  EXPECT_NE(ErrorOf({"--delay-trace", path}).find("line 3 is \"late\""), std::string::npos);
  std::ofstream(path) << "# nothing\n";
  EXPECT_NE(ErrorOf({"--delay-trace", path}).find("holds no delays"), std::string::npos);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace hapticd::netem
