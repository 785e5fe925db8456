#include "clients/cpp/control_client.h"

#include <array>
#include <charconv>
#include <fmt/format.h>
#include <asio/connect.hpp>
#include <asio/read.hpp>
#include <asio/write.hpp>

#include "server/net/control_frame.h"

namespace hapticd::proxy {
namespace {

constexpr uint32_t kProtocolVersion = 1;

// The request's kind as the protocol spells it ("open_session"), for messages.
std::string BodyName(const v1::Request& request) {
  const auto* field = v1::Request::descriptor()->FindFieldByNumber(request.body_case());
  return field != nullptr ? std::string(field->name()) : "request";
}

}  // namespace

HostPort ParseHostPort(std::string_view text) {
  const auto bad = [&](std::string_view why) {
    return std::invalid_argument(fmt::format("\"{}\" is not HOST:PORT: {}", text, why));
  };
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) throw bad("there is no port");
  std::string_view host = text.substr(0, colon);
  const std::string_view port_text = text.substr(colon + 1);
  // [v6]:port: the brackets are not part of the address
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host.empty()) throw bad("the host is empty");
  unsigned port = 0;
  const auto [end, error] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (error != std::errc() || end != port_text.data() + port_text.size() || port > 65535) {
    throw bad(fmt::format("the port \"{}\" is not an integer in [0, 65535]", port_text));
  }
  return {std::string(host), static_cast<uint16_t>(port)};
}

v1::OpenSession MakeOpenSession(const DeviceCaps& caps) {
  v1::OpenSession open;
  open.set_device_type(caps.kind == DeviceKind::kImpedance ? v1::DEVICE_TYPE_IMPEDANCE
                                                           : v1::DEVICE_TYPE_ADMITTANCE);
  open.set_degrees_of_freedom(static_cast<uint32_t>(caps.degrees_of_freedom));
  open.set_max_force(caps.max_force);
  open.set_max_velocity(caps.max_velocity);
  open.set_rate_hz(caps.rate_hz);
  v1::Vec3* start = open.mutable_start();
  start->set_x(caps.start_W.x());
  start->set_y(caps.start_W.y());
  start->set_z(caps.start_W.z());
  return open;
}

ControlClient::ControlClient(const std::string& host, uint16_t port, std::chrono::milliseconds timeout,
                             const std::string& tls_ca_file)
    : server_(fmt::format("{}:{}", host, port)),
      timeout_(timeout),
      tls_context_(asio::ssl::context::tls_client),
      stream_(context_, tls_context_),
      tls_(!tls_ca_file.empty()) {
  asio::ip::tcp::socket& socket = stream_.next_layer();
  // resolve (a numeric address needs no lookup), then connect within the timeout
  std::error_code error;
  asio::ip::tcp::resolver resolver(context_);
  const auto endpoints = resolver.resolve(host, std::to_string(port), error);
  if (error) throw ControlError(fmt::format("cannot resolve {}: {}", server_, error.message()));
  asio::async_connect(socket, endpoints, [&](const std::error_code& e, const asio::ip::tcp::endpoint&) { error = e; });
  RunPending("connecting to");
  if (error) throw ControlError(fmt::format("cannot connect to {}: {}", server_, error.message()));
  // requests are small and each waits for its reply: no Nagle delay
  socket.set_option(asio::ip::tcp::no_delay(true), error);
  if (!tls_) return;

  // TLS 1.2 or later; the server's certificate must chain to the CA file and name host.
  tls_context_.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                           asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                           asio::ssl::context::no_tlsv1_1);
  tls_context_.load_verify_file(tls_ca_file, error);
  if (error) throw ControlError(fmt::format("cannot read the CA file {}: {}", tls_ca_file, error.message()));
  stream_.set_verify_mode(asio::ssl::verify_peer);
  stream_.set_verify_callback(asio::ssl::host_name_verification(host));
  SSL_set_tlsext_host_name(stream_.native_handle(), host.c_str());
  stream_.async_handshake(asio::ssl::stream_base::client, [&](const std::error_code& e) { error = e; });
  RunPending("TLS handshake with");
  if (error) throw ControlError(fmt::format("TLS handshake with {} failed: {}", server_, error.message()));
}

ControlClient::~ControlClient() {
  std::error_code ignored;
  stream_.next_layer().close(ignored);
}

void ControlClient::RunPending(std::string_view what) {
  context_.restart();
  context_.run_for(timeout_);
  if (context_.stopped()) return;
  // still pending: cancel it (its handler runs with operation_aborted) and give up
  std::error_code ignored;
  stream_.next_layer().close(ignored);
  context_.run();
  throw ControlError(fmt::format("{} {} timed out after {} ms", what, server_, timeout_.count()));
}

void ControlClient::WriteFrame(const v1::Request& request) {
  const std::string frame = net::EncodeFrame(request);
  std::error_code error;
  OnStream([&](auto& stream) {
    asio::async_write(stream, asio::buffer(frame), [&](const std::error_code& e, std::size_t) { error = e; });
  });
  RunPending("writing a request to");
  if (error) throw ControlError(fmt::format("writing a request to {} failed: {}", server_, error.message()));
}

v1::Reply ControlClient::ReadReply() {
  // the frame's header, then exactly the length it announces (bounded)
  std::array<uint8_t, net::kFrameHeaderSize> header;
  std::error_code error;
  OnStream([&](auto& stream) {
    asio::async_read(stream, asio::buffer(header), [&](const std::error_code& e, std::size_t) { error = e; });
  });
  RunPending("reading a reply from");
  if (error == asio::error::eof) throw ControlError(fmt::format("{} closed the connection", server_));
  if (error) throw ControlError(fmt::format("reading a reply from {} failed: {}", server_, error.message()));
  const uint32_t length = net::ReadFrameLength(header);
  if (length > net::kMaxFrameSize) {
    throw ControlError(fmt::format("{} announced a frame of {} bytes; the limit is {}", server_, length,
                                   net::kMaxFrameSize));
  }
  std::string body(length, '\0');
  OnStream([&](auto& stream) {
    asio::async_read(stream, asio::buffer(body), [&](const std::error_code& e, std::size_t) { error = e; });
  });
  RunPending("reading a reply from");
  if (error) throw ControlError(fmt::format("reading a reply from {} failed: {}", server_, error.message()));
  v1::Reply reply;
  if (!reply.ParseFromString(body)) {
    throw ControlError(fmt::format("{} sent a reply that does not parse ({} bytes)", server_, length));
  }
  return reply;
}

v1::Reply ControlClient::Call(v1::Request request) {
  const uint64_t id = next_request_id_++;
  request.set_request_id(id);
  WriteFrame(request);
  // skip replies to other requests (telemetry); an error for request 0 is the server
  // failing to read ours
  v1::Reply reply = ReadReply();
  while (reply.request_id() != id && !(reply.request_id() == 0 && reply.has_error())) reply = ReadReply();
  if (reply.has_error()) {
    throw ServerError(fmt::format("{}: {}: {}", BodyName(request), v1::Error::Code_Name(reply.error().code()),
                                  reply.error().message()),
                      reply.error().code());
  }
  return reply;
}

v1::HelloReply ControlClient::Hello(std::string_view client_name, std::string_view access_token) {
  v1::Request request;
  v1::Hello* hello = request.mutable_hello();
  hello->set_protocol_version(kProtocolVersion);
  hello->set_client_name(std::string(client_name));
  hello->set_access_token(std::string(access_token));
  const v1::Reply reply = Call(std::move(request));
  if (!reply.has_hello()) throw ControlError(fmt::format("{} answered hello without a HelloReply", server_));
  return reply.hello();
}

SessionTicket ControlClient::OpenSession(const v1::OpenSession& open) {
  v1::Request request;
  *request.mutable_open_session() = open;
  const v1::Reply reply = Call(std::move(request));
  if (!reply.has_session_opened()) {
    throw ControlError(fmt::format("{} answered open_session without a SessionOpened", server_));
  }
  const v1::SessionOpened& opened = reply.session_opened();
  SessionTicket ticket;
  ticket.session_id = opened.session_id();
  ticket.max_datagram = opened.max_datagram();
  if (opened.session_key().size() != ticket.key.size()) {
    throw ControlError(fmt::format("{} sent a session key of {} bytes; the protocol's are {}", server_,
                                   opened.session_key().size(), ticket.key.size()));
  }
  std::copy(opened.session_key().begin(), opened.session_key().end(), ticket.key.begin());
  // the UDP endpoint: an address, or the control peer's when the server listens on any
  HostPort udp;
  asio::ip::address address;
  try {
    udp = ParseHostPort(opened.udp_endpoint());
    address = asio::ip::make_address(udp.host);
  } catch (const std::exception& e) {
    throw ControlError(fmt::format("{} sent udp_endpoint \"{}\", which is not ADDRESS:PORT ({})", server_,
                                   opened.udp_endpoint(), e.what()));
  }
  std::error_code error;
  if (address.is_unspecified()) address = stream_.next_layer().remote_endpoint(error).address();
  ticket.udp_endpoint = asio::ip::udp::endpoint(address, udp.port);
  return ticket;
}

void ControlClient::CloseSession(uint32_t session_id) {
  v1::Request request;
  request.mutable_close_session()->set_session_id(session_id);
  Call(std::move(request));
}

}  // namespace hapticd::proxy
