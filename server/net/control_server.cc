#include "server/net/control_server.h"

#include <algorithm>
#include <chrono>
#include <deque>
#include <list>
#include <map>

#include <asio/ssl.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>
#include <asio/read.hpp>
#include <fmt/format.h>

#include "server/net/log.h"
#include "server/net/protobuf_log.h"

namespace hapticd::net {
namespace {

using asio::ip::tcp;
using TlsStream = asio::ssl::stream<tcp::socket>;
using Clock = std::chrono::steady_clock;

// Bytes a body read asks for at once: the buffer runs at most this far ahead of what
// arrived.
constexpr std::size_t kReadChunk = 64u << 10;

// Failed Hellos per peer address. Bounded: past kMaxTracked addresses the stalest goes.
class HelloFailures {
 public:
  // Whether address is refused now.
  bool Blocked(const std::string& address, Clock::time_point now) {
    const auto it = entries_.find(address);
    if (it == entries_.end()) return false;
    if (now - it->second.window_start >= kHelloFailureWindow) {
      entries_.erase(it);
      return false;
    }
    return it->second.failures >= kMaxHelloFailures;
  }
  void Record(const std::string& address, Clock::time_point now) {
    if (entries_.size() >= kMaxTracked && !entries_.count(address)) {
      entries_.erase(std::min_element(entries_.begin(), entries_.end(), [](const auto& a, const auto& b) {
        return a.second.window_start < b.second.window_start;
      }));
    }
    Entry& entry = entries_[address];
    if (entry.failures == 0 || now - entry.window_start >= kHelloFailureWindow) entry = {0, now};
    ++entry.failures;
  }

 private:
  static constexpr std::size_t kMaxTracked = 4096;
  struct Entry {
    int failures = 0;
    Clock::time_point window_start;
  };
  std::map<std::string, Entry> entries_;
};

// What every connection shares with the server; lives as long as the server.
struct Shared {
  ControlService& service;
  const ControlServerOptions& options;
  HelloFailures hello_failures;
  LogLimiter refusals{10, std::chrono::seconds(10)};
  uint64_t last_connection_id = 0;
};

class ConnectionBase {
 public:
  virtual ~ConnectionBase() = default;
  virtual void Close() = 0;
};

// One client: frames in, replies and telemetry out (see control_server.h).
template <typename Stream>
class Connection : public ConnectionBase, public std::enable_shared_from_this<Connection<Stream>> {
 public:
  // refusal: non-empty when the connection is refused at once (it is sent as an Error).
  Connection(Stream stream, Shared& shared, std::string peer, std::string address, bool authenticated,
             std::string refusal)
      : stream_(std::move(stream)), shared_(shared), peer_(std::move(peer)), address_(std::move(address)),
        refusal_(std::move(refusal)), deadline_(stream_.get_executor()) {
    state_.authenticated = authenticated;
    state_.id = ++shared_.last_connection_id;
    ++shared_.service.connection_counters().open;
  }

  void Start() {
    Log(LogLevel::kDebug, "control connection from {}", peer_);
    if constexpr (std::is_same_v<Stream, TlsStream>) {
      ArmDeadline(shared_.options.handshake_timeout, "the TLS handshake");
      stream_.async_handshake(asio::ssl::stream_base::server, [self = this->shared_from_this()](std::error_code error) {
        if (error) {
          self->shared_.refusals.Log(LogLevel::kWarning, "TLS handshake with {} failed: {}", self->peer_,
                                     error.message());
          return self->Close();
        }
        self->Begin();
      });
    } else {
      Begin();
    }
  }

  void Close() override {
    if (closed_) return;
    closed_ = true;
    --shared_.service.connection_counters().open;
    shared_.service.ConnectionClosed(state_.id);
    deadline_.cancel();
    for (auto& [id, timer] : timers_) timer->cancel();
    timers_.clear();
    std::error_code ignored;
    stream_.lowest_layer().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.lowest_layer().close(ignored);
    Log(LogLevel::kDebug, "control connection from {} closed", peer_);
  }

 private:
  // After the handshake: serve, or say why not and close.
  void Begin() {
    if (refusal_.empty()) return ReadHeader();
    SendLast(shared_.service.MakeError(0, v1::Error::CODE_RESOURCE_EXHAUSTED, refusal_));
  }

  // (Re)arms the connection's one deadline; on expiry the connection is told what took
  // too long and closed.
  void ArmDeadline(Clock::duration after, std::string what) {
    deadline_.expires_after(after);
    deadline_.async_wait([self = this->shared_from_this(), what = std::move(what), after](std::error_code error) {
      if (error || self->closed_) return;
      ++self->shared_.service.connection_counters().timed_out;
      const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(after).count();
      self->shared_.refusals.Log(LogLevel::kInfo, "control connection from {}: {} took over {} ms; closing",
                                 self->peer_, what, ms);
      // a stalled TLS handshake has no channel to say so on
      if (!self->handshaken()) return self->Close();
      self->SendLast(self->shared_.service.MakeError(
          0, v1::Error::CODE_DEADLINE_EXCEEDED, fmt::format("{} took over {} ms; closing", what, ms)));
    });
  }

  bool handshaken() const {
    if constexpr (std::is_same_v<Stream, TlsStream>) return handshake_done_;
    return true;
  }

  uint32_t frame_limit() const {
    return state_.said_hello ? shared_.options.max_frame_bytes : shared_.options.max_greeting_frame_bytes;
  }

  void ReadHeader() {
    if constexpr (std::is_same_v<Stream, TlsStream>) handshake_done_ = true;
    // waiting for a request: idle unless telemetry flows
    if (state_.subscriptions.empty()) {
      ArmDeadline(shared_.options.idle_timeout, "waiting for a request");
    } else {
      deadline_.cancel();
    }
    asio::async_read(stream_, asio::buffer(header_),
                     [self = this->shared_from_this()](std::error_code error, std::size_t) {
                       if (error) return self->Close();  // the peer left (or sent half a header)
                       const uint32_t length = ReadFrameLength(self->header_);
                       if (length > self->frame_limit()) {
                         const bool greeting = !self->state_.said_hello;
                         return self->SendLast(self->shared_.service.MakeError(
                             0, v1::Error::CODE_FRAME_TOO_LARGE,
                             fmt::format("a frame announced {} bytes; the limit is {} bytes{}; closing", length,
                                         self->frame_limit(), greeting ? " until a Hello succeeds" : "")));
                       }
                       self->ArmDeadline(self->shared_.options.frame_timeout +
                                             std::chrono::seconds(length / kFrameBytesPerSecond),
                                         fmt::format("receiving a frame of {} bytes", length));
                       self->body_.clear();
                       self->ReadBody(length);
                     });
  }

  // Reads the body a chunk at a time: the buffer grows as bytes arrive, not as announced.
  void ReadBody(uint32_t length) {
    if (body_.size() == length) return Serve();
    const std::size_t have = body_.size();
    const std::size_t chunk = std::min<std::size_t>(length - have, kReadChunk);
    body_.resize(have + chunk);
    stream_.async_read_some(asio::buffer(body_.data() + have, chunk),
                            [self = this->shared_from_this(), have, length](std::error_code error, std::size_t n) {
                              if (error) return self->Close();  // the peer left mid-frame
                              self->body_.resize(have + n);
                              self->ReadBody(length);
                            });
  }

  void Serve() {
    v1::Request request;
    std::string refusal;  // why the frame is no request, when it is not
    {
      // what protobuf says of a frame it refuses (a name that is not UTF-8) goes in the reply
      const ProtobufLogCapture protobuf_log;
      if (!request.ParseFromString(body_)) {
        refusal = fmt::format("a frame of {} bytes is not a hapticd.v1.Request", body_.size());
        if (!protobuf_log.diagnostic().empty()) refusal += ": " + protobuf_log.diagnostic();
      }
    }
    if (!refusal.empty()) {
      Send(shared_.service.MakeError(0, v1::Error::CODE_BAD_REQUEST, refusal));
    } else {
      v1::Reply reply = shared_.service.Handle(request, state_);
      if (state_.close_after_reply) {
        shared_.hello_failures.Record(address_, Clock::now());
        return SendLast(reply);
      }
      Send(reply);
      if (state_.subscriptions_changed) SyncSubscriptions();
    }
    body_.clear();
    body_.shrink_to_fit();  // a 10 MB upload's buffer is not kept for the next frame
    // back-pressure: the next request waits until the client has read its replies
    if (queued_bytes_ > shared_.options.max_queued_bytes) {
      deadline_.cancel();
      paused_ = true;
      return;
    }
    ReadHeader();
  }

  // Queues a reply; one over the frame limit becomes an Error naming both sizes.
  void Send(const v1::Reply& reply) {
    if (closed_) return;
    const std::size_t size = reply.ByteSizeLong();
    if (size > shared_.options.max_frame_bytes) {
      return Send(shared_.service.MakeError(
          reply.request_id(), v1::Error::CODE_FRAME_TOO_LARGE,
          fmt::format("the reply would be {} bytes; the limit is {} bytes (ask for less at once)", size,
                      shared_.options.max_frame_bytes)));
    }
    queue_.push_back(EncodeFrame(reply));
    queued_bytes_ += queue_.back().size();
    if (!writing_) WriteNext();
  }

  // The connection's last reply: nothing more is read; it closes once this is written.
  void SendLast(const v1::Reply& reply) {
    close_after_write_ = true;
    paused_ = false;
    deadline_.cancel();
    Send(reply);
  }

  void WriteNext() {
    if (queue_.empty()) {
      writing_ = false;
      if (close_after_write_) Close();
      return;
    }
    writing_ = true;
    asio::async_write(stream_, asio::buffer(queue_.front()),
                      [self = this->shared_from_this()](std::error_code error, std::size_t) {
                        if (error) return self->Close();
                        self->queued_bytes_ -= self->queue_.front().size();
                        self->queue_.pop_front();
                        // the client caught up: read its next request
                        if (self->paused_ && self->queued_bytes_ <= self->shared_.options.max_queued_bytes) {
                          self->paused_ = false;
                          self->ReadHeader();
                        }
                        self->WriteNext();
                      });
  }

  // Starts a timer for each new subscription and drops those of removed ones.
  void SyncSubscriptions() {
    state_.subscriptions_changed = false;
    for (auto it = timers_.begin(); it != timers_.end();) {
      if (state_.subscriptions.count(it->first)) {
        ++it;
      } else {
        it->second->cancel();
        it = timers_.erase(it);
      }
    }
    for (const auto& [id, subscription] : state_.subscriptions) {
      if (timers_.count(id)) continue;
      auto timer = std::make_shared<asio::steady_timer>(stream_.get_executor());
      timer->expires_after(Period(subscription));
      timers_[id] = timer;
      WaitForSample(id, timer);
    }
  }

  // The rate is in [0.1, 1000] Hz (ControlService checks), so this cannot overflow.
  static std::chrono::nanoseconds Period(const Subscription& subscription) {
    return std::chrono::nanoseconds(static_cast<int64_t>(1e9 / subscription.rate_hz));
  }

  void WaitForSample(uint64_t id, std::shared_ptr<asio::steady_timer> timer) {
    timer->async_wait([self = this->shared_from_this(), id, timer](std::error_code error) {
      if (error || self->closed_) return;
      const auto it = self->state_.subscriptions.find(id);
      if (it == self->state_.subscriptions.end()) return;
      // A client that reads slower than its rate loses samples, not server memory.
      if (self->queued_bytes_ < self->shared_.options.max_queued_bytes) {
        v1::Reply reply;
        reply.set_request_id(id);
        *reply.mutable_telemetry() = self->shared_.service.BuildTelemetry(it->second);
        self->Send(reply);
      }
      timer->expires_at(timer->expiry() + Period(it->second));
      self->WaitForSample(id, timer);
    });
  }

  Stream stream_;
  Shared& shared_;
  std::string peer_;     // "address:port", for logs
  std::string address_;  // what failed Hellos count against
  std::string refusal_;
  asio::steady_timer deadline_;
  ConnectionState state_;
  std::array<uint8_t, kFrameHeaderSize> header_{};
  std::string body_;
  std::deque<std::string> queue_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool paused_ = false;
  bool close_after_write_ = false;
  bool closed_ = false;
  bool handshake_done_ = false;
  std::map<uint64_t, std::shared_ptr<asio::steady_timer>> timers_;
};

}  // namespace

struct ControlServer::Impl {
  Impl(asio::io_context& context, ControlService& service, ControlServerOptions options)
      : context(context), options(std::move(options)), shared{service, this->options, {}, {10, std::chrono::seconds(10)}, 0}, acceptor(context),
        tls_context(asio::ssl::context::tls_server), accept_backoff(context) {
    if (this->options.max_frame_bytes < this->options.max_greeting_frame_bytes ||
        this->options.max_frame_bytes > kMaxFrameSize) {
      throw std::invalid_argument(fmt::format("the frame limit is {} bytes; it must be in [{}, {}]",
                                              this->options.max_frame_bytes,
                                              this->options.max_greeting_frame_bytes, kMaxFrameSize));
    }
    if (this->options.tls) {
      // TLS 1.2 or later only.
      tls_context.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                              asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                              asio::ssl::context::no_tlsv1_1);
      try {
        tls_context.use_certificate_chain_file(this->options.tls->certificate_chain);
        tls_context.use_private_key_file(this->options.tls->private_key, asio::ssl::context::pem);
      } catch (const std::system_error& e) {
        throw std::runtime_error(fmt::format("cannot load the TLS certificate {} and key {}: {}",
                                             this->options.tls->certificate_chain,
                                             this->options.tls->private_key, e.what()));
      }
    }
    acceptor.open(this->options.endpoint.protocol());
    acceptor.set_option(tcp::acceptor::reuse_address(true));
    acceptor.bind(this->options.endpoint);
    acceptor.listen();
  }

  void Accept() {
    acceptor.async_accept([this](std::error_code error, tcp::socket socket) {
      // stopped: a handler already due when the acceptor closed ends here
      if (error == asio::error::operation_aborted || !acceptor.is_open()) return;
      if (error) {
        // out of descriptors (or another transient failure): wait before the next try,
        // longer each time, rather than spin on a full table
        accept_failures_in_row = std::min(accept_failures_in_row + 1, 10);
        const auto wait = std::min(std::chrono::milliseconds(10 << accept_failures_in_row),
                                   std::chrono::milliseconds(1000));
        accept_log.Log(LogLevel::kWarning, "accept failed: {}; retrying in {} ms", error.message(), wait.count());
        accept_backoff.expires_after(wait);
        accept_backoff.async_wait([this](std::error_code e) {
          if (!e && acceptor.is_open()) Accept();
        });
        return;
      }
      accept_failures_in_row = 0;
      Admit(std::move(socket));
      Accept();
    });
  }

  void Admit(tcp::socket socket) {
    std::error_code ignored;
    socket.set_option(tcp::no_delay(true), ignored);
    const auto remote = socket.remote_endpoint(ignored);
    const std::string address = remote.address().to_string();
    const std::string peer = fmt::format("{}:{}", address, remote.port());
    // With a token, every connection Hellos with it; without one, only loopback is served.
    const bool trusted = remote.address().is_loopback() && shared.service.options().access_token.empty();
    ConnectionCounters& counters = shared.service.connection_counters();
    std::string refusal;
    if (shared.hello_failures.Blocked(address, Clock::now())) {
      refusal = fmt::format("{} failed {} Hellos within {} s; try again later", address, kMaxHelloFailures,
                            kHelloFailureWindow.count());
    } else if (counters.open >= options.max_connections) {
      refusal = fmt::format("the server has {} control connections, the most it serves (--max-connections)",
                            counters.open);
    }
    if (!refusal.empty()) {
      ++counters.refused;
      shared.refusals.Log(LogLevel::kWarning, "refused a control connection from {}: {}", peer, refusal);
    }
    std::shared_ptr<ConnectionBase> connection;
    if (options.tls) {
      auto tls = std::make_shared<Connection<TlsStream>>(TlsStream(std::move(socket), tls_context), shared, peer,
                                                         address, trusted, refusal);
      tls->Start();
      connection = tls;
    } else {
      auto plain = std::make_shared<Connection<tcp::socket>>(std::move(socket), shared, peer, address, trusted,
                                                             refusal);
      plain->Start();
      connection = plain;
    }
    connections.remove_if([](const auto& weak) { return weak.expired(); });
    connections.push_back(connection);
  }

  asio::io_context& context;
  ControlServerOptions options;
  Shared shared;
  tcp::acceptor acceptor;
  asio::ssl::context tls_context;
  asio::steady_timer accept_backoff;
  int accept_failures_in_row = 0;
  LogLimiter accept_log{5, std::chrono::seconds(10)};
  std::list<std::weak_ptr<ConnectionBase>> connections;
};

ControlServer::ControlServer(asio::io_context& context, ControlService& service, ControlServerOptions options)
    : impl_(std::make_unique<Impl>(context, service, std::move(options))) {}

ControlServer::~ControlServer() = default;

tcp::endpoint ControlServer::local_endpoint() const { return impl_->acceptor.local_endpoint(); }

void ControlServer::Start() { impl_->Accept(); }

void ControlServer::Stop() {
  std::error_code ignored;
  impl_->acceptor.close(ignored);
  impl_->accept_backoff.cancel();
  for (auto& weak : impl_->connections) {
    if (auto connection = weak.lock()) connection->Close();
  }
  impl_->connections.clear();
}

}  // namespace hapticd::net
