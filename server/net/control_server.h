#pragma once
// The control channel's transport: a TCP acceptor on the control thread's io_context
// and one connection per client, plain or TLS (asio's OpenSSL streams).
//
// A connection reads a frame header, checks the length against the limit, reads the
// message, parses it, lets ControlService serve it and queues the reply; then the next
// frame. A frame that does not parse gets an Error reply and the connection carries on
// (its boundary is known); a frame over the limit gets an Error reply and the
// connection is closed after it (the rest of the stream cannot be trusted). Telemetry
// subscriptions are timers on the same io_context; when a client reads too slowly its
// samples are skipped rather than queued without bound.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include "server/net/control_service.h"

namespace hapticd::net {

struct TlsFiles {
  std::string certificate_chain;  // PEM
  std::string private_key;        // PEM
};

struct ControlServerOptions {
  asio::ip::tcp::endpoint endpoint;
  std::optional<TlsFiles> tls;  // nullopt: plain TCP
  // A connection from another host must Hello with the token first; loopback peers are
  // trusted when this is false.
  bool require_token_on_loopback = false;
  std::size_t max_queued_bytes = 32u << 20;  // per connection, before telemetry is skipped
};

class ControlServer {
 public:
  // Binds and listens. Throws std::system_error (address in use ...) or
  // std::runtime_error (unreadable TLS files), naming what failed.
  ControlServer(asio::io_context& context, ControlService& service, ControlServerOptions options);
  ~ControlServer();

  asio::ip::tcp::endpoint local_endpoint() const;
  // Accepts until Stop; Stop closes the acceptor and every connection.
  void Start();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hapticd::net
