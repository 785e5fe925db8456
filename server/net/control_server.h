#pragma once
// The control channel's transport: a TCP acceptor on the control thread's io_context
// and one connection per client, plain or TLS (asio's OpenSSL streams).
//
// Theory of operation, one connection:
//
//   accept ──> TLS handshake (handshake_timeout) ──> header ──> body ──> serve ──┐
//                                                      ^                          │
//                                                      └── reply queued ──────────┘
//
//   - A frame header's length is checked against the connection's limit first: before
//     a successful Hello max_greeting_frame_bytes, after it max_frame_bytes. Over it:
//     FRAME_TOO_LARGE, and the connection closes after that reply (the rest of the
//     stream cannot be trusted). A frame that does not parse gets an Error reply and the
//     connection carries on (its boundary is known).
//   - The body buffer grows only as bytes arrive (a read chunk ahead at most), and the
//     whole frame must arrive within frame_timeout plus one second per
//     kFrameBytesPerSecond of its length; a connection waiting for its next frame with no
//     subscription is closed after idle_timeout. Each deadline ends in a
//     DEADLINE_EXCEEDED reply and a close.
//   - While a connection's unsent replies exceed max_queued_bytes its next request is
//     not read (back-pressure: nothing is dropped) and its telemetry samples are skipped.
//     A reply larger than max_frame_bytes is replaced by an Error naming both sizes.
//   - A failed Hello (ControlService sets close_after_reply) closes the connection after
//     its error; an address with kMaxHelloFailures failures within kHelloFailureWindow is
//     refused for that long. Connections past max_connections are refused with an Error.
//   - accept failures (descriptors exhausted) back off up to a second, and their log
//     lines are rate-limited.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include "server/net/control_frame.h"
#include "server/net/control_service.h"

namespace hapticd::net {

struct TlsFiles {
  std::string certificate_chain;  // PEM
  std::string private_key;        // PEM
};

struct ControlServerOptions {
  asio::ip::tcp::endpoint endpoint;
  std::optional<TlsFiles> tls;  // nullopt: plain TCP
  std::size_t max_queued_bytes = 32u << 20;  // per connection: back-pressure and skipped telemetry past it
  std::size_t max_connections = 64;          // at once
  uint32_t max_frame_bytes = kMaxFrameSize;  // after a successful Hello, in [4096, kMaxFrameSize]
  uint32_t max_greeting_frame_bytes = 4096;  // before it
  std::chrono::milliseconds handshake_timeout{10'000};
  std::chrono::milliseconds frame_timeout{30'000};  // plus 1 s per kFrameBytesPerSecond
  std::chrono::milliseconds idle_timeout{600'000};
};

// The slowest a frame may arrive, past its frame_timeout.
inline constexpr std::size_t kFrameBytesPerSecond = 64u << 10;
// Failed Hellos from one address within the window block it for the window.
inline constexpr int kMaxHelloFailures = 5;
inline constexpr std::chrono::seconds kHelloFailureWindow{60};

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
