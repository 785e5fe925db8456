#include "server/net/control_server.h"

#include <chrono>
#include <deque>
#include <list>

#include <asio/read.hpp>
#include <asio/ssl.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>
#include <fmt/format.h>

#include "server/net/control_frame.h"
#include "server/net/log.h"

namespace hapticd::net {
namespace {

using asio::ip::tcp;
using TlsStream = asio::ssl::stream<tcp::socket>;

class ConnectionBase {
 public:
  virtual ~ConnectionBase() = default;
  virtual void Close() = 0;
};

// One client: frames in, replies and telemetry out (see control_server.h).
template <typename Stream>
class Connection : public ConnectionBase, public std::enable_shared_from_this<Connection<Stream>> {
 public:
  Connection(Stream stream, ControlService& service, std::string peer, bool authenticated,
             std::size_t max_queued_bytes)
      : stream_(std::move(stream)), service_(service), peer_(std::move(peer)), max_queued_bytes_(max_queued_bytes) {
    state_.authenticated = authenticated;
  }

  void Start() {
    Log(LogLevel::kDebug, "control connection from {}", peer_);
    if constexpr (std::is_same_v<Stream, TlsStream>) {
      stream_.async_handshake(asio::ssl::stream_base::server, [self = this->shared_from_this()](std::error_code error) {
        if (error) {
          Log(LogLevel::kWarning, "TLS handshake with {} failed: {}", self->peer_, error.message());
          return self->Close();
        }
        self->ReadHeader();
      });
    } else {
      ReadHeader();
    }
  }

  void Close() override {
    if (closed_) return;
    closed_ = true;
    for (auto& [id, timer] : timers_) timer->cancel();
    timers_.clear();
    std::error_code ignored;
    stream_.lowest_layer().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.lowest_layer().close(ignored);
    Log(LogLevel::kDebug, "control connection from {} closed", peer_);
  }

 private:
  void ReadHeader() {
    asio::async_read(stream_, asio::buffer(header_),
                     [self = this->shared_from_this()](std::error_code error, std::size_t) {
                       if (error) return self->Close();  // the peer left (or sent half a header)
                       const uint32_t length = ReadFrameLength(self->header_);
                       if (length > kMaxFrameSize) {
                         self->close_after_write_ = true;
                         return self->Send(self->service_.MakeError(
                             0, v1::Error::CODE_FRAME_TOO_LARGE,
                             fmt::format("a frame announced {} bytes; the limit is {} bytes; closing", length,
                                         kMaxFrameSize)));
                       }
                       self->body_.resize(length);
                       self->ReadBody();
                     });
  }

  void ReadBody() {
    asio::async_read(stream_, asio::buffer(body_), [self = this->shared_from_this()](std::error_code error, std::size_t) {
      if (error) return self->Close();  // the peer left mid-frame
      v1::Request request;
      if (!request.ParseFromString(self->body_)) {
        self->Send(self->service_.MakeError(
            0, v1::Error::CODE_BAD_REQUEST,
            fmt::format("a frame of {} bytes is not a hapticd.v1.Request", self->body_.size())));
      } else {
        self->Send(self->service_.Handle(request, self->state_));
        if (self->state_.subscriptions_changed) self->SyncSubscriptions();
      }
      self->body_.clear();
      self->body_.shrink_to_fit();  // a 10 MB upload's buffer is not kept for the next frame
      self->ReadHeader();
    });
  }

  void Send(const v1::Reply& reply) {
    if (closed_) return;
    queue_.push_back(EncodeFrame(reply));
    queued_bytes_ += queue_.back().size();
    if (!writing_) WriteNext();
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

  static std::chrono::nanoseconds Period(const Subscription& subscription) {
    return std::chrono::nanoseconds(static_cast<int64_t>(1e9 / subscription.rate_hz));
  }

  void WaitForSample(uint64_t id, std::shared_ptr<asio::steady_timer> timer) {
    timer->async_wait([self = this->shared_from_this(), id, timer](std::error_code error) {
      if (error || self->closed_) return;
      const auto it = self->state_.subscriptions.find(id);
      if (it == self->state_.subscriptions.end()) return;
      // A client that reads slower than its rate loses samples, not server memory.
      if (self->queued_bytes_ < self->max_queued_bytes_) {
        v1::Reply reply;
        reply.set_request_id(id);
        *reply.mutable_telemetry() = self->service_.BuildTelemetry(it->second);
        self->Send(reply);
      }
      timer->expires_at(timer->expiry() + Period(it->second));
      self->WaitForSample(id, timer);
    });
  }

  Stream stream_;
  ControlService& service_;
  std::string peer_;
  std::size_t max_queued_bytes_;
  ConnectionState state_;
  std::array<uint8_t, kFrameHeaderSize> header_{};
  std::string body_;
  std::deque<std::string> queue_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool close_after_write_ = false;
  bool closed_ = false;
  std::map<uint64_t, std::shared_ptr<asio::steady_timer>> timers_;
};

}  // namespace

struct ControlServer::Impl {
  Impl(asio::io_context& context, ControlService& service, ControlServerOptions options)
      : context(context), service(service), options(std::move(options)), acceptor(context),
        tls_context(asio::ssl::context::tls_server) {
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
      if (error) {
        if (error != asio::error::operation_aborted) {
          Log(LogLevel::kWarning, "accept failed: {}", error.message());
          Accept();
        }
        return;
      }
      std::error_code ignored;
      socket.set_option(tcp::no_delay(true), ignored);
      const auto remote = socket.remote_endpoint(ignored);
      const std::string peer = fmt::format("{}:{}", remote.address().to_string(), remote.port());
      const bool trusted = remote.address().is_loopback() && !options.require_token_on_loopback;
      std::shared_ptr<ConnectionBase> connection;
      if (options.tls) {
        auto tls = std::make_shared<Connection<TlsStream>>(TlsStream(std::move(socket), tls_context), service,
                                                           peer, trusted, options.max_queued_bytes);
        tls->Start();
        connection = tls;
      } else {
        auto plain = std::make_shared<Connection<tcp::socket>>(std::move(socket), service, peer, trusted,
                                                               options.max_queued_bytes);
        plain->Start();
        connection = plain;
      }
      connections.remove_if([](const auto& weak) { return weak.expired(); });
      connections.push_back(connection);
      Accept();
    });
  }

  asio::io_context& context;
  ControlService& service;
  ControlServerOptions options;
  tcp::acceptor acceptor;
  asio::ssl::context tls_context;
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
  for (auto& weak : impl_->connections) {
    if (auto connection = weak.lock()) connection->Close();
  }
  impl_->connections.clear();
}

}  // namespace hapticd::net
