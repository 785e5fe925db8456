// The control channel's transport over real loopback TCP: frame limits before and after
// Hello, deadlines, connection caps, failed Hellos, back-pressure and reply sizes.
#include "server/net/control_server.h"

#include <chrono>
#include <future>
#include <optional>
#include <string>
#include <thread>

#include <asio/connect.hpp>
#include <asio/read.hpp>
#include <asio/write.hpp>
#include <gtest/gtest.h>

#include "server/net/protobuf_log.h"
#include "server/net/test/net_harness.h"

namespace hapticd::net {
namespace {

using namespace std::chrono_literals;
using asio::ip::tcp;
using testing::Harness;

// A control server on a loopback port, its io_context on a thread of its own.
class ServerThread {
 public:
  explicit ServerThread(ControlServerOptions options, std::string token = "")
      : harness_(), service_(MakeService(token)) {
    options.endpoint = tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0);
    server_.emplace(context_, *service_, options);
    server_->Start();
    thread_ = std::thread([this] { context_.run(); });
  }
  ~ServerThread() {
    asio::post(context_, [this] { server_->Stop(); });
    context_.stop();
    thread_.join();
  }
  uint16_t port() const { return server_->local_endpoint().port(); }
  // Counters, read on the server's thread.
  ConnectionCounters counters() {
    std::promise<ConnectionCounters> done;
    asio::post(context_, [&] { done.set_value(service_->connection_counters()); });
    return done.get_future().get();
  }

 private:
  std::unique_ptr<ControlService> MakeService(const std::string& token) {
    ServiceOptions options = harness_.Options();
    options.access_token = token;
    return std::make_unique<ControlService>(testing::MakeTestScene(), harness_.publisher, harness_.sessions,
                                            harness_.realtime.counters(), options);
  }

  Harness harness_;
  std::unique_ptr<ControlService> service_;
  asio::io_context context_;
  std::optional<ControlServer> server_;
  std::thread thread_;
};

// A blocking client: frames out, replies in.
class Client {
 public:
  explicit Client(uint16_t port) : socket_(context_) {
    socket_.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  }
  void SendBytes(const std::string& bytes) { asio::write(socket_, asio::buffer(bytes)); }
  void Send(const v1::Request& request) { SendBytes(EncodeFrame(request)); }
  // The next reply, or nullopt when the server closed the connection first.
  std::optional<v1::Reply> Receive() {
    std::array<uint8_t, kFrameHeaderSize> header{};
    std::error_code error;
    asio::read(socket_, asio::buffer(header), error);
    if (error) return std::nullopt;
    std::string body(ReadFrameLength(header), '\0');
    asio::read(socket_, asio::buffer(body), error);
    if (error) return std::nullopt;
    v1::Reply reply;
    EXPECT_TRUE(reply.ParseFromString(body));
    return reply;
  }
  // Whether the server has closed the connection (a read ends at once).
  bool Closed() {
    char byte;
    std::error_code error;
    socket_.read_some(asio::buffer(&byte, 1), error);
    return error == asio::error::eof || error == asio::error::connection_reset;
  }
  void Hello(const std::string& token = "") {
    v1::Request hello;
    hello.set_request_id(1);
    hello.mutable_hello()->set_protocol_version(1);
    hello.mutable_hello()->set_access_token(token);
    Send(hello);
    const auto reply = Receive();
    ASSERT_TRUE(reply && reply->has_hello()) << (reply ? reply->DebugString() : "closed");
  }

 private:
  asio::io_context context_;
  tcp::socket socket_;
};

std::string Header(uint32_t length) {
  std::string header(kFrameHeaderSize, '\0');
  for (int i = 0; i < 4; ++i) header[i] = static_cast<char>(length >> (24 - 8 * i));
  return header;
}

void ExpectLastError(Client& client, v1::Error::Code code, const std::string& message) {
  const auto reply = client.Receive();
  ASSERT_TRUE(reply && reply->has_error()) << (reply ? reply->DebugString() : "closed without a reply");
  EXPECT_EQ(reply->error().code(), code);
  EXPECT_EQ(reply->error().message(), message);
  EXPECT_TRUE(client.Closed());
}

v1::Request GetScene(uint64_t id) {
  v1::Request request;
  request.set_request_id(id);
  request.mutable_get_scene();
  return request;
}

// Before a Hello succeeds a frame is small; after it, up to the deployment's limit.
TEST(ControlServer, FramesAreSmallUntilAHelloSucceeds) {
  ControlServerOptions options;
  options.max_frame_bytes = 1 << 20;
  ServerThread server(options);
  {
    Client client(server.port());
    client.SendBytes(Header(64u << 20));
    ExpectLastError(client, v1::Error::CODE_FRAME_TOO_LARGE,
                    "a frame announced 67108864 bytes; the limit is 4096 bytes until a Hello succeeds; closing");
  }
  {
    Client client(server.port());
    client.Hello();
    // a small request is served, a frame of exactly the limit is read whole ...
    client.Send(GetScene(2));
    ASSERT_TRUE(client.Receive()->has_scene());
    client.SendBytes(Header(1 << 20) + std::string(1 << 20, '\xff'));
    const auto garbage = client.Receive();
    ASSERT_TRUE(garbage && garbage->has_error());
    EXPECT_EQ(garbage->error().message(), "a frame of 1048576 bytes is not a hapticd.v1.Request");
    // ... and one byte more is refused before any of it is read
    client.SendBytes(Header((1 << 20) + 1));
    ExpectLastError(client, v1::Error::CODE_FRAME_TOO_LARGE,
                    "a frame announced 1048577 bytes; the limit is 1048576 bytes; closing");
  }
}

// A request protobuf refuses for a string that is not UTF-8: the reply names the field,
// the server's log holds no line of protobuf's own, and the connection goes on.
TEST(ControlServer, ARequestWithANameThatIsNotUtf8IsRefusedByName) {
  RouteProtobufLog();
  ServerThread server(ControlServerOptions{});
  Client client(server.port());
  client.Hello();
  v1::Request request;
  request.set_request_id(2);
  request.mutable_add_object()->mutable_object()->set_name("AAAA");
  std::string bytes = request.SerializeAsString();
  bytes.replace(bytes.find("AAAA"), 4, "caf\xe9");
  ::testing::internal::CaptureStderr();
  for (int i = 0; i < 100; ++i) {
    client.SendBytes(Header(static_cast<uint32_t>(bytes.size())) + bytes);
    const auto refused = client.Receive();
    ASSERT_TRUE(refused && refused->has_error());
    EXPECT_EQ(refused->error().code(), v1::Error::CODE_BAD_REQUEST);
    EXPECT_EQ(refused->error().message(), "a frame of " + std::to_string(bytes.size()) +
                                              " bytes is not a hapticd.v1.Request: hapticd.v1.Object.name is not "
                                              "valid UTF-8");
  }
  EXPECT_EQ(::testing::internal::GetCapturedStderr().find("protobuf"), std::string::npos);
  client.Send(GetScene(3));
  ASSERT_TRUE(client.Receive()->has_scene());
}

// A frame begun must arrive within its deadline; a connection with nothing to do is
// closed after the idle timeout; both say why and count.
TEST(ControlServer, StalledFramesAndIdleConnectionsAreClosed) {
  ControlServerOptions options;
  options.frame_timeout = 200ms;
  options.idle_timeout = 300ms;
  ServerThread server(options);
  {
    Client client(server.port());
    client.SendBytes(Header(1000) + std::string(10, 'x'));  // then nothing
    ExpectLastError(client, v1::Error::CODE_DEADLINE_EXCEEDED,
                    "receiving a frame of 1000 bytes took over 200 ms; closing");
  }
  {
    Client client(server.port());
    const auto start = std::chrono::steady_clock::now();
    ExpectLastError(client, v1::Error::CODE_DEADLINE_EXCEEDED, "waiting for a request took over 300 ms; closing");
    EXPECT_GE(std::chrono::steady_clock::now() - start, 300ms);
  }
  EXPECT_EQ(server.counters().timed_out, 2u);
  EXPECT_EQ(server.counters().open, 0u);
}

// One connection past the cap is refused with a reason; the others are served.
TEST(ControlServer, ConnectionsPastTheCapAreRefused) {
  ControlServerOptions options;
  options.max_connections = 2;
  ServerThread server(options);
  Client first(server.port());
  Client second(server.port());
  first.Hello();
  second.Hello();
  Client third(server.port());
  ExpectLastError(third, v1::Error::CODE_RESOURCE_EXHAUSTED,
                  "the server has 2 control connections, the most it serves (--max-connections)");
  first.Send(GetScene(3));
  EXPECT_TRUE(first.Receive()->has_scene());
  const ConnectionCounters counters = server.counters();
  EXPECT_EQ(counters.refused, 1u);
  EXPECT_EQ(counters.open, 2u);
}

// With a token, loopback connections too must Hello with it. A failed Hello closes the
// connection; after kMaxHelloFailures of them the address is refused for a while.
TEST(ControlServer, FailedHellosCloseAndBlockTheAddress) {
  const std::string token = "0123456789abcdef-token";
  ServerThread server(ControlServerOptions{}, token);
  {
    Client client(server.port());
    client.Send(GetScene(1));
    const auto refused = client.Receive();
    ASSERT_TRUE(refused && refused->has_error());
    EXPECT_EQ(refused->error().code(), v1::Error::CODE_UNAUTHENTICATED);
  }
  for (int attempt = 0; attempt < kMaxHelloFailures; ++attempt) {
    Client client(server.port());
    v1::Request hello;
    hello.mutable_hello()->set_protocol_version(1);
    hello.mutable_hello()->set_access_token("not the token");
    client.Send(hello);
    ExpectLastError(client, v1::Error::CODE_UNAUTHENTICATED,
                    "hello.access_token is not this server's token; closing the connection");
  }
  Client blocked(server.port());
  ExpectLastError(blocked, v1::Error::CODE_RESOURCE_EXHAUSTED, "127.0.0.1 failed 5 Hellos within 60 s; try again later");
  const ConnectionCounters counters = server.counters();
  EXPECT_EQ(counters.hello_failures, 5u);
  EXPECT_EQ(counters.refused, 1u);
}

// A client that pipelines requests without reading their replies stops being read once
// its replies pass the cap; when it reads them all, every one is there, in order.
TEST(ControlServer, UnreadRepliesPauseReadingAndNothingIsLost) {
  ControlServerOptions options;
  options.max_queued_bytes = 4096;
  ServerThread server(options);
  Client client(server.port());
  client.Hello();
  constexpr int kRequests = 2000;
  std::thread writer([&] {
    for (int i = 0; i < kRequests; ++i) client.Send(GetScene(100 + i));
  });
  // another client is served meanwhile
  std::this_thread::sleep_for(100ms);
  Client other(server.port());
  other.Hello();
  other.Send(GetScene(7));
  EXPECT_TRUE(other.Receive()->has_scene());
  for (int i = 0; i < kRequests; ++i) {
    const auto reply = client.Receive();
    ASSERT_TRUE(reply && reply->has_scene()) << i;
    ASSERT_EQ(reply->request_id(), 100u + i);
  }
  writer.join();
}

// A reply over the frame limit becomes an error naming both sizes; the connection
// carries on.
TEST(ControlServer, AReplyOverTheLimitIsRefusedByName) {
  ControlServerOptions options;
  options.max_frame_bytes = 8192;
  ServerThread server(options);
  Client client(server.port());
  client.Hello();
  // each hit names the object it hit: a long name makes the reply outgrow the request
  v1::Request add;
  add.set_request_id(8);
  v1::Object* ball = add.mutable_add_object()->mutable_object();
  ball->set_name(std::string(120, 'b'));
  ball->mutable_shape()->mutable_sphere()->set_radius(0.1);
  ball->mutable_pose()->mutable_position()->set_z(0.5);
  ball->mutable_material()->set_stiffness(1000);
  client.Send(add);
  ASSERT_TRUE(client.Receive()->has_done());
  v1::Request batch;
  batch.set_request_id(9);
  v1::RayCastBatch* rays = batch.mutable_ray_cast_batch();
  for (int i = 0; i < 60; ++i) {
    for (double v : {0.0, 0.0, 1.0}) rays->add_origins(v);
    for (double v : {0.0, 0.0, -1.0}) rays->add_directions(v);
  }
  rays->set_max_distance(5);
  client.Send(batch);
  const auto reply = client.Receive();
  ASSERT_TRUE(reply && reply->has_error()) << reply->DebugString();
  EXPECT_EQ(reply->request_id(), 9u);
  EXPECT_EQ(reply->error().code(), v1::Error::CODE_FRAME_TOO_LARGE);
  EXPECT_EQ(reply->error().message().rfind("the reply would be ", 0), 0u) << reply->error().message();
  EXPECT_NE(reply->error().message().find("bytes; the limit is 8192 bytes"), std::string::npos);
  client.Send(GetScene(10));
  EXPECT_TRUE(client.Receive()->has_scene());
}

}  // namespace
}  // namespace hapticd::net
