#include "server/app/server_options.h"

#include <vector>

#include <gtest/gtest.h>

#include "server/app/default_scene.h"

namespace hapticd::app {
namespace {

ServerOptions Parse(std::vector<std::string_view> args) { return ParseServerOptions(args); }

std::string ErrorOf(std::vector<std::string_view> args) {
  try {
    Parse(args);
  } catch (const OptionsError& e) {
    return e.what();
  }
  return "";
}

TEST(ServerOptions, DefaultsToLoopback) {
  const ServerOptions options = Parse({});
  EXPECT_EQ(options.host, "127.0.0.1");
  EXPECT_FALSE(options.help);
  EXPECT_TRUE(options.scene_file.empty());
  const ServerOptions free_ports = Parse({"--tcp-port", "0", "--udp-port", "0", "--log-level", "debug"});
  EXPECT_EQ(free_ports.tcp_port, 0);
  EXPECT_EQ(free_ports.udp_port, 0);
  EXPECT_EQ(free_ports.log_level, net::LogLevel::kDebug);
  EXPECT_TRUE(Parse({"--help"}).help);
  EXPECT_FALSE(options.version);
  // --version wins over what follows it, as --help does
  EXPECT_TRUE(Parse({"--version", "--tcp-port", "70000"}).version);
}

TEST(ServerOptions, NamesTheBadOption) {
  EXPECT_EQ(ErrorOf({"--tcp-port", "70000"}), "--tcp-port is \"70000\"; it must be a whole number from 0 to 65535");
  EXPECT_EQ(ErrorOf({"--udp-port", "12x"}), "--udp-port is \"12x\"; it must be a whole number from 0 to 65535");
  EXPECT_EQ(ErrorOf({"--udp-port"}), "--udp-port needs a value");
  EXPECT_EQ(ErrorOf({"--colour", "red"}), "unknown option \"--colour\" (see --help)");
  // unknown first: an unknown option at the end is not "short of a value"
  EXPECT_EQ(ErrorOf({"--bogus"}), "unknown option \"--bogus\" (see --help)");
  EXPECT_EQ(ErrorOf({"stray"}), "unexpected argument \"stray\"");
  EXPECT_EQ(ErrorOf({"--log-level", "loud"}), "--log-level is \"loud\"; it must be debug, info, warning or error");
  EXPECT_EQ(ErrorOf({"--host", "localhost"}), "--host is \"localhost\"; it is not an IP address");
  EXPECT_EQ(ErrorOf({"--tls-cert", "c.pem"}), "--tls-cert and --tls-key go together; give both or neither");
  EXPECT_EQ(ErrorOf({"--ray-backend", "optix"}), "--ray-backend is \"optix\"; it must be native or embree");
  EXPECT_EQ(Parse({"--ray-backend", "embree"}).ray_backend, scene::RayBackend::kEmbree);
  EXPECT_EQ(Parse({}).ray_backend, scene::RayBackend::kNative);
}

TEST(ServerOptions, BudgetsAreSetAndBounded) {
  const ServerOptions defaults = Parse({});
  EXPECT_EQ(defaults.scene_budgets.max_objects, 1024u);
  EXPECT_EQ(defaults.max_connections, 64u);
  EXPECT_EQ(defaults.max_request_bytes, 64u << 20);
  const ServerOptions set = Parse({"--max-objects", "10", "--max-mesh-triangles", "5000", "--max-scene-triangles",
                                   "9000", "--max-connections", "3", "--max-request-bytes", "100000",
                                   "--idle-timeout", "30"});
  EXPECT_EQ(set.scene_budgets.max_objects, 10u);
  EXPECT_EQ(set.scene_budgets.max_triangles_per_mesh, 5000u);
  EXPECT_EQ(set.scene_budgets.max_triangles, 9000u);
  EXPECT_EQ(set.max_connections, 3u);
  EXPECT_EQ(set.max_request_bytes, 100000u);
  EXPECT_EQ(set.idle_timeout_s, 30);
  EXPECT_EQ(ErrorOf({"--max-objects", "0"}), "--max-objects is \"0\"; it must be a whole number from 1 to 65536");
  EXPECT_EQ(ErrorOf({"--max-request-bytes", "100"}),
            "--max-request-bytes is \"100\"; it must be a whole number from 4096 to 67108864");
  EXPECT_EQ(ErrorOf({"--idle-timeout", "-5"}), "--idle-timeout is \"-5\"; it must be a whole number from 1 to 86400");
  // the work of one query request
  EXPECT_EQ(defaults.max_request_work, 100'000'000);
  EXPECT_EQ(Parse({"--max-request-work", "20000"}).max_request_work, 20000);
  EXPECT_EQ(ErrorOf({"--max-request-work", "9999"}),
            "--max-request-work is \"9999\"; it must be a whole number from 10000 to 1000000000000");
  EXPECT_EQ(ErrorOf({"--max-request-work"}), "--max-request-work needs a value");
}

TEST(ServerOptions, LeavingLoopbackNeedsTlsAndAToken) {
  EXPECT_EQ(ErrorOf({"--host", "0.0.0.0"}),
            "--host is 0.0.0.0, not loopback: the control channel then needs TLS (--tls-cert, --tls-key) and an "
            "access token (--access-token-file)");
  EXPECT_NE(ErrorOf({"--host", "10.0.0.1", "--tls-cert", "c", "--tls-key", "k"}), "");
  EXPECT_EQ(ErrorOf({"--host", "10.0.0.1", "--tls-cert", "c", "--tls-key", "k", "--access-token-file", "t"}), "");
  EXPECT_EQ(ErrorOf({"--host", "::1"}), "");
  EXPECT_EQ(ErrorOf({"--observer-token-file", "o"}), "--observer-token-file needs --access-token-file (the operator's token)");
  EXPECT_EQ(ErrorOf({"--observer-token-file", "o", "--access-token-file", "t"}), "");
}

TEST(DefaultScene, BuildsWithItsMeshKeptAsAMesh) {
  scene::SceneBuilder builder;
  for (const auto& spec : MakeDefaultScene()) builder.Add(spec);
  const auto snapshot = builder.Build(1);
  ASSERT_EQ(snapshot->num_objects(), 5);
  const int ring = snapshot->FindObject("ring");
  ASSERT_GE(ring, 0);
  EXPECT_EQ(snapshot->object(ring).representation.chosen, scene::Representation::kMesh);
  EXPECT_EQ(std::get<scene::MeshShape>(snapshot->object(ring).shape).bvh->mesh().num_triangles(), 48 * 24 * 2);
}

}  // namespace
}  // namespace hapticd::app
