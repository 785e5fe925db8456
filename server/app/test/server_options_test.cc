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
}

TEST(ServerOptions, NamesTheBadOption) {
  EXPECT_EQ(ErrorOf({"--tcp-port", "70000"}), "--tcp-port is \"70000\"; it must be a whole number from 0 to 65535");
  EXPECT_EQ(ErrorOf({"--udp-port", "12x"}), "--udp-port is \"12x\"; it must be a whole number from 0 to 65535");
  EXPECT_EQ(ErrorOf({"--udp-port"}), "--udp-port needs a value");
  EXPECT_EQ(ErrorOf({"--colour", "red"}), "unknown option \"--colour\" (see --help)");
  EXPECT_EQ(ErrorOf({"--log-level", "loud"}), "--log-level is \"loud\"; it must be debug, info, warning or error");
  EXPECT_EQ(ErrorOf({"--host", "localhost"}), "--host is \"localhost\"; it is not an IP address");
  EXPECT_EQ(ErrorOf({"--tls-cert", "c.pem"}), "--tls-cert and --tls-key go together; give both or neither");
  EXPECT_EQ(ErrorOf({"--ray-backend", "optix"}), "--ray-backend is \"optix\"; it must be native or embree");
  EXPECT_EQ(Parse({"--ray-backend", "embree"}).ray_backend, scene::RayBackend::kEmbree);
  EXPECT_EQ(Parse({}).ray_backend, scene::RayBackend::kNative);
}

TEST(ServerOptions, LeavingLoopbackNeedsTlsAndAToken) {
  EXPECT_EQ(ErrorOf({"--host", "0.0.0.0"}),
            "--host is 0.0.0.0, not loopback: the control channel then needs TLS (--tls-cert, --tls-key) and an "
            "access token (--access-token-file)");
  EXPECT_NE(ErrorOf({"--host", "10.0.0.1", "--tls-cert", "c", "--tls-key", "k"}), "");
  EXPECT_EQ(ErrorOf({"--host", "10.0.0.1", "--tls-cert", "c", "--tls-key", "k", "--access-token-file", "t"}), "");
  EXPECT_EQ(ErrorOf({"--host", "::1"}), "");
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
