#include "clients/cpp/proxy_options.h"

#include <vector>

#include <gtest/gtest.h>

namespace hapticd::proxy {
namespace {

ProxyOptions Parse(std::vector<std::string_view> args) { return ParseProxyOptions(args); }

// The message of the OptionsError that args raise.
std::string ErrorOf(std::vector<std::string_view> args) {
  try {
    Parse(args);
  } catch (const OptionsError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ProxyOptions, Defaults) {
  const ProxyOptions options = Parse({"--server", "127.0.0.1:7460"});
  EXPECT_FALSE(options.echo);
  EXPECT_EQ(options.target.host, "127.0.0.1");
  EXPECT_EQ(options.target.port, 7460);
  EXPECT_EQ(options.seconds, 5);
  EXPECT_EQ(options.rate_hz, 1000);
  EXPECT_EQ(options.sessions, 1);
  EXPECT_EQ(options.threads, 1);
  EXPECT_EQ(options.mode, DeviceKind::kImpedance);
  EXPECT_EQ(options.path, PathKind::kStroke);
  EXPECT_EQ(options.realtime_priority, 20);
}

TEST(ProxyOptions, VersionNeedsNoServer) {
  EXPECT_TRUE(Parse({"--version"}).version);
  EXPECT_FALSE(Parse({"--server", "127.0.0.1:7460"}).version);
}

TEST(ProxyOptions, ReadsEveryOption) {
  const ProxyOptions options =
      Parse({"--echo=localhost:9", "--seconds", "2.5", "--rate-hz", "500", "--sessions", "25", "--threads", "2",
             "--mode", "admittance", "--path", "press", "--max-force=4", "--budget-us", "300", "--miss-threshold-us", "50", "--hold-ms", "20",
             "--ramp-ms", "0", "--timeout-s", "1", "--realtime-priority", "0"});
  EXPECT_TRUE(options.echo);
  EXPECT_EQ(options.target.port, 9);
  EXPECT_EQ(options.seconds, 2.5);
  EXPECT_EQ(options.rate_hz, 500);
  EXPECT_EQ(options.sessions, 25);
  EXPECT_EQ(options.threads, 2);
  EXPECT_EQ(options.mode, DeviceKind::kAdmittance);
  EXPECT_EQ(options.path, PathKind::kPress);
  EXPECT_EQ(options.max_force, 4);
  EXPECT_EQ(options.budget_us, 300);
  EXPECT_EQ(options.miss_threshold_us, 50);
  EXPECT_EQ(options.hold_ms, 20);
  EXPECT_EQ(options.ramp_ms, 0);
  EXPECT_EQ(options.timeout_s, 1);
  EXPECT_EQ(options.realtime_priority, 0);
}

TEST(ProxyOptions, SendsTheRealtimeDatagramsViaARelay) {
  const ProxyOptions options = Parse({"--server", "127.0.0.1:7460", "--udp-via", "10.0.0.2:9000"});
  EXPECT_EQ(options.udp_via.host, "10.0.0.2");
  EXPECT_EQ(options.udp_via.port, 9000);
  EXPECT_TRUE(Parse({"--server", "127.0.0.1:7460"}).udp_via.host.empty());
  EXPECT_EQ(ErrorOf({"--echo", "127.0.0.1:9", "--udp-via", "127.0.0.1:8"}),
            "--udp-via goes with --server (with --echo, name the relay as the echo)");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--udp-via", "relay"}), "--udp-via \"relay\" is not HOST:PORT: there is no port");
}

TEST(ProxyOptions, ChoosesWhereTheForceIsRendered) {
  EXPECT_FALSE(Parse({"--server", "a:1"}).local_model);
  EXPECT_FALSE(Parse({"--server", "a:1", "--remote-mode", "direct"}).local_model);
  EXPECT_TRUE(Parse({"--server", "a:1", "--remote-mode", "local-model"}).local_model);
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--remote-mode", "local"}),
            "--remote-mode is \"local\"; it must be direct or local-model");
  const std::string refused = "--remote-mode local-model is for an impedance device served by hapticd (--server)";
  EXPECT_EQ(ErrorOf({"--echo", "a:1", "--remote-mode", "local-model"}), refused);
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--mode", "admittance", "--remote-mode", "local-model"}), refused);
}

TEST(ProxyOptions, ReadsTheChannelsPassivityAndDeadband) {
  const ProxyOptions plain = Parse({"--server", "a:1"});
  EXPECT_FALSE(plain.tdpa);
  EXPECT_FALSE(plain.deadband.on());
  const ProxyOptions options =
      Parse({"--server", "a:1", "--tdpa", "--deadband", "0.1", "--deadband-force-floor", "0.05",
             "--deadband-position-floor=0.0002", "--deadband-velocity-floor", "0.004", "--keepalive-ms", "20"});
  EXPECT_TRUE(options.tdpa);
  EXPECT_EQ(options.deadband.weber, 0.1);
  EXPECT_EQ(options.deadband.force_floor_n, 0.05);
  EXPECT_EQ(options.deadband.position_floor_m, 0.0002);
  EXPECT_EQ(options.deadband.velocity_floor_mps, 0.004);
  EXPECT_EQ(options.deadband.keepalive_s, 0.02);
  // the defaults: the server's (remote::DeadbandSettings)
  const ProxyOptions defaults = Parse({"--server", "a:1", "--deadband", "0.2"});
  EXPECT_EQ(defaults.deadband.force_floor_n, remote::kForceFloorN);
  EXPECT_EQ(defaults.deadband.keepalive_s, 0.01);
  // out of bounds, or where it cannot apply
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--deadband", "1"}), "--deadband is 1; a Weber fraction must be in [0, 1) (0: off)");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--deadband-force-floor", "0"}), "--deadband-force-floor is 0; it must be in (0, 10]");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--deadband-position-floor", "1"}),
            "--deadband-position-floor is 1; it must be in (0, 0.01]");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--keepalive-ms", "50"}), "--keepalive-ms is 50; it must be in (0, 25]");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--tdpa=yes"}), "--tdpa takes no value (\"yes\")");
  EXPECT_EQ(ErrorOf({"--echo", "a:1", "--tdpa"}), "--tdpa is for an impedance device served by hapticd (--server)");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--mode", "admittance", "--deadband", "0.1"}),
            "--deadband is for an impedance device served by hapticd (--server)");
}

TEST(ProxyOptions, HelpNeedsNothingElse) { EXPECT_TRUE(Parse({"--help"}).help); }

TEST(ProxyOptions, BadValuesAreNamed) {
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--rate-hz", "0"}), "--rate-hz is 0; it must be in [1, 10000]");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--seconds", "abc"}), "--seconds is \"abc\"; it must be a number");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--sessions", "2.5"}), "--sessions is 2.5; it must be an integer");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--threads", "0"}), "--threads is 0; it must be in [1, 64]");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--sessions", "3", "--threads", "4"}),
            "--threads is 4; it must be at most --sessions (3): a loop serves one session at least");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1:7460", "--mode", "rigid"}),
            "--mode is \"rigid\"; it must be impedance or admittance");
  EXPECT_EQ(ErrorOf({"--server", "127.0.0.1"}), "--server \"127.0.0.1\" is not HOST:PORT: there is no port");
  EXPECT_EQ(ErrorOf({"--seconds", "1"}), "give --server HOST:PORT or --echo HOST:PORT (see --help)");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--echo", "b:2"}), "--echo b:2: give one of --server and --echo, once");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--frobnicate", "3"}), "unknown option --frobnicate (see --help)");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--seconds"}), "--seconds needs a value");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "stray"}), "unexpected argument \"stray\"");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--seconds", "3600", "--sessions", "1000"}),
            "--seconds 3600 x --rate-hz 1000 x --sessions 1000 is 3.6e+09 samples; at most 2e+07 are buffered");
}

TEST(ProxyOptions, ReadsACustomPath) {
  const ProxyOptions options = Parse({"--server", "a:1", "--path", "0,0,0,0.02;1,0.05,0,-0.001"});
  EXPECT_EQ(options.path, PathKind::kCustom);
  ASSERT_EQ(options.custom_path.size(), 2u);
  EXPECT_EQ(options.custom_path[1].t, 1);
  EXPECT_EQ(options.custom_path[1].p_W, Vector3(0.05, 0, -0.001));
}

TEST(ProxyOptions, BadPathsAreNamed) {
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--path", "0,0,0"}), "--path point 0 (\"0,0,0\") is not t,x,y,z");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--path", "0,0,0,0,0"}), "--path point 0 (\"0,0,0,0,0\") is not t,x,y,z");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--path", "1,0,0,0;1,0,0,0"}),
            "--path point 1 (\"1,0,0,0\") has t = 1; it must be after the previous point's 1");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--path", "0,0,x,0"}),
            "--path point 0 (\"0,0,x,0\") is \"x\"; it must be a number");
  EXPECT_EQ(ErrorOf({"--server", "a:1", "--path", ""}), "--path is empty; it needs at least one t,x,y,z point");
}

}  // namespace
}  // namespace hapticd::proxy
