#pragma once
// A blocking client for hapticd's control channel (TCP): frames of a 4-byte big-endian
// length and one protobuf Request or Reply (server/net/control_frame.h).
//
// Plain TCP, which the server accepts on loopback, or TLS (asio's OpenSSL stream, the
// server's certificate checked against a CA file and the host name), which it requires
// off loopback together with a Hello carrying its access token.
//
// Each call writes one request and reads frames until the reply with its request_id
// (telemetry of other requests is skipped), all within the client's timeout; asio's
// asynchronous operations run on a private io_context for at most that long (asio's
// blocking_tcp_client pattern), so no call can hang on a silent server.
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/ip/udp.hpp>
#include <asio/ssl.hpp>

#include "clients/cpp/device_driver.h"
#include "hapticd/v1/hapticd.pb.h"
#include "server/net/datagram_codec.h"

namespace hapticd::proxy {

// The transport failed: cannot connect, the connection broke, a timeout, or a reply
// that is not a well-formed frame. The message names the server and what failed.
class ControlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The server answered with an Error reply; what() is "<request>: <CODE>: <server's message>".
class ServerError : public std::runtime_error {
 public:
  ServerError(const std::string& what, v1::Error::Code code) : std::runtime_error(what), code_(code) {}
  v1::Error::Code code() const { return code_; }

 private:
  v1::Error::Code code_;
};

// A "host:port" pair; the host may be a name, an IPv4 address or a bracketed IPv6 one.
struct HostPort {
  std::string host;
  uint16_t port = 0;
};

// Splits "host:port" ("[::1]:7460" for IPv6). Throws std::invalid_argument naming text
// when there is no port, the port is not an integer in [0, 65535] or the host is empty.
HostPort ParseHostPort(std::string_view text);

// What a session needs on the realtime channel.
struct SessionTicket {
  uint32_t session_id = 0;
  net::SessionKey key{};
  asio::ip::udp::endpoint udp_endpoint;
  uint32_t max_datagram = 0;  // bytes
};

// The capability handshake for a device with these caps: its kind, degrees of freedom,
// force and velocity limits, rate and start position; the server's defaults otherwise
// (point avatar, god-object method).
v1::OpenSession MakeOpenSession(const DeviceCaps& caps);

class ControlClient {
 public:
  // Connects to host:port (resolving the name); with a non-empty tls_ca_file, over TLS
  // trusting that PEM file's certificates for host. Throws ControlError naming
  // host:port and the reason (refused, timed out, certificate not trusted) when it
  // cannot within timeout.
  ControlClient(const std::string& host, uint16_t port,
                std::chrono::milliseconds timeout = std::chrono::seconds(5),
                const std::string& tls_ca_file = {});
  ~ControlClient();
  ControlClient(const ControlClient&) = delete;
  ControlClient& operator=(const ControlClient&) = delete;

  // The server's name and UDP endpoint; protocol version 1.
  v1::HelloReply Hello(std::string_view client_name, std::string_view access_token = {});

  // Opens a session. The ticket's UDP endpoint is the server's, with an unspecified
  // address (0.0.0.0, ::) replaced by the control connection's peer. Throws ServerError
  // when refused, ControlError when the reply is not a usable SessionOpened.
  SessionTicket OpenSession(const v1::OpenSession& open);

  // Closes a session; ServerError (CODE_NOT_FOUND) when no such session is open.
  void CloseSession(uint32_t session_id);

  // Sends request (its request_id is set here) and returns the matching reply. Throws
  // ServerError for an Error reply, ControlError when the transport fails.
  v1::Reply Call(v1::Request request);

 private:
  // Runs the io_context until the pending operation completes, or closes the socket and
  // throws ControlError("<what> <server>: timed out ...") after the timeout.
  void RunPending(std::string_view what);
  // Calls operation with the stream the bytes go through: TLS or the bare socket.
  template <typename Operation>
  void OnStream(Operation&& operation) {
    if (tls_) {
      operation(stream_);
    } else {
      operation(stream_.next_layer());
    }
  }
  void WriteFrame(const v1::Request& request);
  v1::Reply ReadReply();

  std::string server_;  // "host:port", for messages
  std::chrono::milliseconds timeout_;
  asio::io_context context_;
  asio::ssl::context tls_context_;
  asio::ssl::stream<asio::ip::tcp::socket> stream_;  // its TCP layer alone when !tls_
  bool tls_ = false;
  uint64_t next_request_id_ = 1;
};

}  // namespace hapticd::proxy
