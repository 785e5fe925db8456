#pragma once
// hapticd assembled: the scene's snapshot publisher, the session table, the realtime
// channel (its own thread) and the control channel (this thread's io_context).
#include <memory>
#include <string>
#include "server/app/server_options.h"
#include "server/scene/scene_builder.h"

namespace hapticd::app {

class Server {
 public:
  // Binds both channels and publishes the initial scene (version 1). Throws on a busy
  // port, unreadable TLS files or token, naming what failed.
  Server(const ServerOptions& options, scene::SceneBuilder initial);
  ~Server();

  // The bound endpoints as the first stdout line announces them:
  // {"tcp": "127.0.0.1:40123", "udp": "127.0.0.1:40124"}.
  std::string EndpointsJson() const;

  // Serves until SIGINT or SIGTERM, then stops both channels and returns.
  void Run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int realtime_priority_;
};

}  // namespace hapticd::app
