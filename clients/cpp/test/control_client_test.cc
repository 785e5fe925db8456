#include "clients/cpp/control_client.h"

#include <functional>
#include <optional>
#include <thread>

#include <gtest/gtest.h>
#include <asio/read.hpp>
#include <asio/write.hpp>

#include "server/net/control_frame.h"

namespace hapticd::proxy {
namespace {

// A one-connection control server on a loopback port, in a thread: it reads requests
// and answers each with what `answer` makes of it (nothing: stays silent).
class TinyServer {
 public:
  using Answer = std::function<std::vector<v1::Reply>(const v1::Request&)>;

  explicit TinyServer(Answer answer)
      : acceptor_(context_, asio::ip::tcp::endpoint(asio::ip::address_v4::loopback(), 0)),
        answer_(std::move(answer)),
        thread_([this] { Serve(); }) {}
  // Joins the thread, which ends when the client closes its connection: destroy the
  // client first.
  ~TinyServer() { thread_.join(); }

  uint16_t port() const { return acceptor_.local_endpoint().port(); }

 private:
  void Serve() {
    std::error_code error;
    socket_.emplace(acceptor_.accept(error));
    if (error) return;
    for (;;) {
      std::array<uint8_t, net::kFrameHeaderSize> header;
      asio::read(*socket_, asio::buffer(header), error);
      if (error) return;
      std::string body(net::ReadFrameLength(header), '\0');
      asio::read(*socket_, asio::buffer(body), error);
      if (error) return;
      v1::Request request;
      request.ParseFromString(body);
      for (const v1::Reply& reply : answer_(request)) {
        asio::write(*socket_, asio::buffer(net::EncodeFrame(reply)), error);
      }
    }
  }

  asio::io_context context_;
  asio::ip::tcp::acceptor acceptor_;
  Answer answer_;
  std::optional<asio::ip::tcp::socket> socket_;
  std::thread thread_;
};

TEST(ControlClient, OpensASessionOnTheControlPeersAddress) {
  TinyServer server([](const v1::Request& request) {
    EXPECT_TRUE(request.has_open_session());
    EXPECT_EQ(request.open_session().device_type(), v1::DEVICE_TYPE_IMPEDANCE);
    EXPECT_EQ(request.open_session().max_force(), 7);
    EXPECT_EQ(request.open_session().start().z(), 0.1);
    // telemetry for another request first: skipped
    v1::Reply other;
    other.set_request_id(request.request_id() + 100);
    other.mutable_telemetry();
    v1::Reply reply;
    reply.set_request_id(request.request_id());
    v1::SessionOpened* opened = reply.mutable_session_opened();
    opened->set_session_id(42);
    opened->set_session_key(std::string(32, '\x07'));
    opened->set_udp_endpoint("0.0.0.0:7461");
    opened->set_max_datagram(512);
    return std::vector<v1::Reply>{other, reply};
  });
  ControlClient client("127.0.0.1", server.port());
  DeviceCaps caps;
  caps.max_force = 7;
  caps.start_W = Vector3(0, 0, 0.1);
  const SessionTicket ticket = client.OpenSession(MakeOpenSession(caps));
  EXPECT_EQ(ticket.session_id, 42u);
  EXPECT_EQ(ticket.key[31], 7);
  EXPECT_EQ(ticket.max_datagram, 512u);
  // the server listens on any address: the UDP endpoint is where the control peer is
  EXPECT_EQ(ticket.udp_endpoint.address().to_string(), "127.0.0.1");
  EXPECT_EQ(ticket.udp_endpoint.port(), 7461);
}

TEST(ControlClient, AnErrorReplyNamesTheServersMessage) {
  TinyServer server([](const v1::Request& request) {
    v1::Reply reply;
    reply.set_request_id(request.request_id());
    reply.mutable_error()->set_code(v1::Error::CODE_NOT_FOUND);
    reply.mutable_error()->set_message("close_session.session_id is 0x00000009; no open session has that id");
    return std::vector<v1::Reply>{reply};
  });
  ControlClient client("127.0.0.1", server.port());
  try {
    client.CloseSession(9);
    FAIL() << "no ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::CODE_NOT_FOUND);
    EXPECT_STREQ(e.what(),
                 "close_session: CODE_NOT_FOUND: close_session.session_id is 0x00000009; no open session has that id");
  }
}

TEST(ControlClient, ASilentServerTimesOut) {
  TinyServer server([](const v1::Request&) { return std::vector<v1::Reply>{}; });
  ControlClient client("127.0.0.1", server.port(), std::chrono::milliseconds(50));
  try {
    client.Hello("test");
    FAIL() << "no ControlError";
  } catch (const ControlError& e) {
    EXPECT_EQ(std::string(e.what()), "reading a reply from 127.0.0.1:" + std::to_string(server.port()) +
                                         " timed out after 50 ms");
  }
}

TEST(ControlClient, ARefusedConnectionNamesTheServer) {
  // a port that was free a moment ago: nobody listens there now
  uint16_t port;
  {
    asio::io_context context;
    asio::ip::tcp::acceptor probe(context, asio::ip::tcp::endpoint(asio::ip::address_v4::loopback(), 0));
    port = probe.local_endpoint().port();
  }
  try {
    ControlClient client("127.0.0.1", port);
    FAIL() << "connected to a closed port";
  } catch (const ControlError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot connect to 127.0.0.1:" + std::to_string(port)), std::string::npos)
        << e.what();
  }
}

TEST(ControlClient, AnOversizedFrameIsRefused) {
  // a server that announces 100 MiB: refused before reading it
  asio::io_context context;
  asio::ip::tcp::acceptor acceptor(context, asio::ip::tcp::endpoint(asio::ip::address_v4::loopback(), 0));
  std::thread liar([&] {
    asio::ip::tcp::socket peer = acceptor.accept();
    std::array<uint8_t, 64> request;
    peer.read_some(asio::buffer(request));
    const std::array<uint8_t, 4> header{0x06, 0x40, 0x00, 0x00};
    asio::write(peer, asio::buffer(header));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  });
  ControlClient client("127.0.0.1", acceptor.local_endpoint().port());
  EXPECT_THROW(
      {
        try {
          client.Hello("test");
        } catch (const ControlError& e) {
          EXPECT_NE(std::string(e.what()).find("announced a frame of 104857600 bytes"), std::string::npos) << e.what();
          throw;
        }
      },
      ControlError);
  liar.join();
}

TEST(ParseHostPort, SplitsAndNamesBadInput) {
  EXPECT_EQ(ParseHostPort("127.0.0.1:7460").host, "127.0.0.1");
  EXPECT_EQ(ParseHostPort("127.0.0.1:7460").port, 7460);
  EXPECT_EQ(ParseHostPort("[::1]:0").host, "::1");
  EXPECT_EQ(ParseHostPort("localhost:65535").port, 65535);
  try {
    ParseHostPort("localhost:70000");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "\"localhost:70000\" is not HOST:PORT: the port \"70000\" is not an integer in [0, 65535]");
  }
  EXPECT_THROW(ParseHostPort("localhost"), std::invalid_argument);
  EXPECT_THROW(ParseHostPort(":80"), std::invalid_argument);
  EXPECT_THROW(ParseHostPort("host:8x"), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::proxy
