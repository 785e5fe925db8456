// hapticd: the haptic rendering server. See server_options.cc for the command line.
#include <cstdio>
#include <iostream>
#include <string_view>
#include <vector>

#include "server/app/default_scene.h"
#include "server/app/server.h"
#include "server/app/server_options.h"
#include "hapticd/version.h"
#include "server/net/log.h"
#include "server/net/protobuf_log.h"
#include "server/sim/scenario_parser.h"

namespace {

using hapticd::net::Log;
using hapticd::net::LogLevel;

// The initial scene: the file's, or the embedded default.
hapticd::scene::SceneBuilder LoadInitialScene(const hapticd::app::ServerOptions& options) {
  if (options.scene_file.empty()) {
    hapticd::scene::SceneSettings settings;
    settings.ray_backend = options.ray_backend;
    settings.budgets = options.scene_budgets;
    hapticd::scene::SceneBuilder builder(settings);
    for (const auto& spec : hapticd::app::MakeDefaultScene()) builder.Add(spec);
    return builder;
  }
  hapticd::sim::SceneFile file = hapticd::sim::LoadSceneFile(options.scene_file);
  file.settings.ray_backend = options.ray_backend;
  file.settings.budgets = options.scene_budgets;
  hapticd::scene::SceneBuilder builder(file.settings);
  for (const auto& spec : file.objects) builder.Add(spec);
  return builder;
}

}  // namespace

int main(int argc, char** argv) {
  hapticd::app::ServerOptions options;
  try {
    const std::vector<std::string_view> args(argv + 1, argv + argc);
    options = hapticd::app::ParseServerOptions(args);
  } catch (const hapticd::app::OptionsError& e) {
    std::fprintf(stderr, "hapticd: %s\n", e.what());
    return 2;
  }
  if (options.help) {
    std::cout << hapticd::app::Usage();
    return 0;
  }
  if (options.version) {
    std::cout << "hapticd " << hapticd::kVersion << '\n';
    return 0;
  }
  hapticd::net::SetLogLevel(options.log_level);
  // before any thread starts: protobuf's lines (a peer's bad request) go through hapticd's log
  hapticd::net::RouteProtobufLog();

  try {
    hapticd::scene::SceneBuilder scene = LoadInitialScene(options);
    hapticd::app::Server server(options, std::move(scene));
    // The endpoints line first, flushed, so whoever started us can connect.
    std::cout << server.EndpointsJson() << std::endl;
    server.Run();
  } catch (const hapticd::sim::ScenarioError& e) {
    Log(LogLevel::kError, "--scene {}: {}", options.scene_file, e.what());
    return 2;
  } catch (const hapticd::scene::SceneError& e) {
    Log(LogLevel::kError, "--scene {}: {}", options.scene_file, e.what());
    return 2;
  } catch (const std::exception& e) {
    Log(LogLevel::kError, "cannot serve: {}", e.what());
    return 1;
  }
  return 0;
}
