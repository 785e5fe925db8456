#include "server/netem/relay.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <poll.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

namespace hapticd::netem {
namespace {

constexpr int kBatch = 32;
constexpr int kMaxDatagram = 65536;
constexpr std::size_t kKeptBufferBytes = 4096;

int64_t NowNs() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// The endpoint's IPv4 address (a name resolved, its first IPv4 address); throws
// std::runtime_error naming the flag when there is none.
sockaddr_in ToAddress(const char* flag, const Endpoint& endpoint) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(endpoint.port));
  if (inet_pton(AF_INET, endpoint.host.c_str(), &address.sin_addr) == 1) return address;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int error = getaddrinfo(endpoint.host.c_str(), nullptr, &hints, &found);
  if (error != 0 || found == nullptr) {
    throw std::runtime_error(fmt::format("{} {}:{}: cannot resolve \"{}\" ({})", flag, endpoint.host, endpoint.port,
                                         endpoint.host, gai_strerror(error)));
  }
  address.sin_addr = reinterpret_cast<const sockaddr_in*>(found->ai_addr)->sin_addr;
  freeaddrinfo(found);
  return address;
}

bool SameAddress(const sockaddr_in& a, const sockaddr_in& b) {
  return a.sin_port == b.sin_port && a.sin_addr.s_addr == b.sin_addr.s_addr;
}

// The receive batch: fixed buffers, filled by one recvmmsg.
struct Batch {
  std::array<std::array<uint8_t, kMaxDatagram>, kBatch> data;
  std::array<iovec, kBatch> iov;
  std::array<mmsghdr, kBatch> headers;
  std::array<sockaddr_in, kBatch> from;

  // Receives what is waiting on fd (non-blocking); returns how many.
  int Receive(int fd) {
    for (int i = 0; i < kBatch; ++i) {
      iov[i] = {data[i].data(), data[i].size()};
      headers[i] = {};
      headers[i].msg_hdr.msg_iov = &iov[i];
      headers[i].msg_hdr.msg_iovlen = 1;
      headers[i].msg_hdr.msg_name = &from[i];
      headers[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
    }
    const int n = recvmmsg(fd, headers.data(), kBatch, MSG_DONTWAIT, nullptr);
    return n < 0 ? 0 : n;
  }
};

Batch& TheBatch() {
  static Batch batch;  // 2 MB: not on the stack
  return batch;
}

void AppendDirection(std::string& out, const char* name, const DirectionStats& s, int held) {
  const auto ms = [](const DelayHistogram& h, double q) { return static_cast<double>(h.Quantile(q)) / 1e6; };
  out += fmt::format(
      "\"{}\": {{\"in\": {}, \"out\": {}, \"lost\": {}, \"duplicated\": {}, \"reordered\": {}, \"overflow\": {}, "
      "\"unsent\": {}, \"held\": {}, \"delay_ms\": {{\"p50\": {:.4f}, \"p99\": {:.4f}, \"max\": {:.4f}}}, "
      "\"late_ms\": {{\"p50\": {:.4f}, \"p99\": {:.4f}, \"max\": {:.4f}}}}}",
      name, s.in, s.out, s.lost, s.duplicated, s.reordered, s.overflow, s.unsent, held, ms(s.applied, 0.5),
      ms(s.applied, 0.99), ms(s.applied, 1), ms(s.late, 0.5), ms(s.late, 0.99), ms(s.late, 1));
}

}  // namespace

struct Relay::Flow {
  sockaddr_in device{};
  int fd = -1;  // connected to the server
  Impairment up, down;
  int64_t last_active_ns = 0;
  uint64_t generation = 0;
  Flow(const ImpairmentSpec& u, const ImpairmentSpec& d, uint64_t seed, int number)
      : up(u, StreamSeed(seed, number, 0)), down(d, StreamSeed(seed, number, 1)) {}
  ~Flow() {
    if (fd >= 0) close(fd);
  }
};

Relay::Relay(const NetemOptions& options) : options_(options), flows_(options.max_flows) {
  forward_ = ToAddress("--forward", options.forward);
  listen_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  const sockaddr_in listen = ToAddress("--listen", options.listen);
  if (listen_fd_ < 0 || bind(listen_fd_, reinterpret_cast<const sockaddr*>(&listen), sizeof(listen)) != 0) {
    throw std::runtime_error(fmt::format("--listen {}:{}: cannot bind ({})", options.listen.host,
                                         options.listen.port, std::strerror(errno)));
  }
  // a deep receive buffer: a burst waits in the kernel rather than being lost there
  const int bytes = 4 << 20;
  setsockopt(listen_fd_, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof(bytes));
  timer_fd_ = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (timer_fd_ < 0) throw std::runtime_error(fmt::format("timerfd_create: {}", std::strerror(errno)));
  // releases are deadlines: no timer slack, and the real-time class when granted
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  if (options.realtime_priority > 0) {
    sched_param param{};
    param.sched_priority = options.realtime_priority;
    realtime_ = sched_setscheduler(0, SCHED_FIFO, &param) == 0;
  }
  // every buffer a queue may hold, made now: none is allocated while relaying
  const int buffers = 2 * options.queue_limit;
  buffers_.resize(static_cast<size_t>(buffers));
  free_buffers_.reserve(static_cast<size_t>(buffers));
  for (int i = buffers - 1; i >= 0; --i) free_buffers_.push_back(i);
  queue_.reserve(static_cast<size_t>(buffers));
}

Relay::~Relay() {
  if (listen_fd_ >= 0) close(listen_fd_);
  if (timer_fd_ >= 0) close(timer_fd_);
}

std::string Relay::listen_endpoint() const {
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &length);
  char host[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &bound.sin_addr, host, sizeof(host));
  return fmt::format("{}:{}", host, ntohs(bound.sin_port));
}

int Relay::FlowFor(const sockaddr_in& device, int64_t now_ns) {
  int free_slot = -1, idlest = -1;
  for (int i = 0; i < static_cast<int>(flows_.size()); ++i) {
    const Flow* flow = flows_[i].get();
    if (flow == nullptr) {
      if (free_slot < 0) free_slot = i;
      continue;
    }
    if (SameAddress(flow->device, device)) return i;
    if (idlest < 0 || flow->last_active_ns < flows_[idlest]->last_active_ns) idlest = i;
  }
  int slot = free_slot;
  if (slot < 0) {
    const int64_t idle_ns = static_cast<int64_t>(options_.flow_idle_s * 1e9);
    if (idlest < 0 || now_ns - flows_[idlest]->last_active_ns < idle_ns) return -1;
    slot = idlest;
  }
  auto flow = std::make_unique<Flow>(options_.up, options_.down, options_.seed, flows_seen_);
  flow->device = device;
  flow->fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (flow->fd < 0 || connect(flow->fd, reinterpret_cast<const sockaddr*>(&forward_), sizeof(forward_)) != 0) {
    std::fprintf(stderr, "hapticd-netem: a flow's socket towards the server: %s\n", std::strerror(errno));
    return -1;
  }
  flow->generation = static_cast<uint64_t>(flows_seen_) + 1;
  ++flows_seen_;
  flows_[slot] = std::move(flow);
  return slot;
}

void Relay::Enqueue(int direction, int slot, const uint8_t* data, int bytes, int64_t now_ns) {
  DirectionStats& stats = stats_[direction];
  ++stats.in;
  Flow& flow = *flows_[slot];
  const Fate fate = (direction == 0 ? flow.up : flow.down).Decide(now_ns, static_cast<size_t>(bytes));
  if (fate.copies == 0) {
    ++stats.lost;
    return;
  }
  stats.reordered += fate.reordered;
  for (int copy = 0; copy < fate.copies; ++copy) {
    if (queued_[direction] >= options_.queue_limit || queued_bytes_[direction] + bytes > kMaxQueuedBytes ||
        free_buffers_.empty()) {
      ++stats.overflow;
      continue;
    }
    if (copy == 1) ++stats.duplicated;
    const int buffer = free_buffers_.back();
    free_buffers_.pop_back();
    buffers_[buffer].assign(data, data + bytes);
    stats.applied.Record(fate.release_ns - now_ns);
    queue_.push_back({fate.release_ns, next_order_++, direction, slot, flow.generation, buffer, bytes});
    std::push_heap(queue_.begin(), queue_.end(), Pending::Later);
    ++queued_[direction];
    queued_bytes_[direction] += bytes;
  }
}

void Relay::ReceiveFromDevices(int64_t now_ns) {
  Batch& batch = TheBatch();
  for (int n; (n = batch.Receive(listen_fd_)) > 0;) {
    for (int i = 0; i < n; ++i) {
      if (batch.headers[i].msg_hdr.msg_flags & MSG_TRUNC) {
        ++truncated_;
        continue;
      }
      const int slot = FlowFor(batch.from[i], now_ns);
      if (slot < 0) {
        ++refused_;
        continue;
      }
      flows_[slot]->last_active_ns = now_ns;
      Enqueue(0, slot, batch.data[i].data(), static_cast<int>(batch.headers[i].msg_len), now_ns);
    }
    if (n < kBatch) break;
  }
}

void Relay::ReceiveFromServer(int slot, int64_t now_ns) {
  Batch& batch = TheBatch();
  for (int n; (n = batch.Receive(flows_[slot]->fd)) > 0;) {
    for (int i = 0; i < n; ++i) {
      if (batch.headers[i].msg_hdr.msg_flags & MSG_TRUNC) {
        ++truncated_;
        continue;
      }
      Enqueue(1, slot, batch.data[i].data(), static_cast<int>(batch.headers[i].msg_len), now_ns);
    }
    if (n < kBatch) break;
  }
}

void Relay::SendDue(int64_t now_ns) {
  while (!queue_.empty() && queue_.front().release_ns <= now_ns) {
    std::pop_heap(queue_.begin(), queue_.end(), Pending::Later);
    const Pending p = queue_.back();
    queue_.pop_back();
    --queued_[p.direction];
    queued_bytes_[p.direction] -= p.bytes;
    DirectionStats& stats = stats_[p.direction];
    const Flow* flow = flows_[p.flow].get();
    bool sent = false;
    if (flow != nullptr && flow->generation == p.generation) {
      const uint8_t* data = buffers_[p.buffer].data();
      sent = p.direction == 0
                 ? send(flow->fd, data, static_cast<size_t>(p.bytes), MSG_DONTWAIT) == p.bytes
                 : sendto(listen_fd_, data, static_cast<size_t>(p.bytes), MSG_DONTWAIT,
                          reinterpret_cast<const sockaddr*>(&flow->device), sizeof(flow->device)) == p.bytes;
    }
    if (sent) {
      ++stats.out;
      stats.late.Record(NowNs() - p.release_ns);
    } else {
      ++stats.unsent;
    }
    // a buffer grown by a large datagram gives its memory back: what is kept stays
    // bounded by the buffers' count, not by the largest datagram each has held
    if (buffers_[p.buffer].capacity() > kKeptBufferBytes) buffers_[p.buffer] = {};
    free_buffers_.push_back(p.buffer);
  }
}

void Relay::ArmTimer() {
  itimerspec spec{};
  if (!queue_.empty()) {
    const int64_t at = std::max<int64_t>(queue_.front().release_ns - 1000 * options_.spin_us, 1);
    spec.it_value = {static_cast<time_t>(at / 1'000'000'000), static_cast<long>(at % 1'000'000'000)};
  }
  timerfd_settime(timer_fd_, TFD_TIMER_ABSTIME, &spec, nullptr);
}

void Relay::Run(int stop_fd) {
  const int64_t start = NowNs();
  const int64_t end = options_.duration_s > 0 ? start + static_cast<int64_t>(options_.duration_s * 1e9) : INT64_MAX;
  std::vector<pollfd> fds;
  std::vector<int> slot_of;  // fds[3 + k] is flows_[slot_of[k]]'s
  for (;;) {
    fds.assign({{stop_fd, POLLIN, 0}, {timer_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}});
    slot_of.clear();
    for (int i = 0; i < static_cast<int>(flows_.size()); ++i) {
      if (flows_[i] == nullptr) continue;
      fds.push_back({flows_[i]->fd, POLLIN, 0});
      slot_of.push_back(i);
    }
    const int64_t now = NowNs();
    if (now >= end) return ReceiveWaiting(now);
    const int64_t wait_ns = std::min<int64_t>(end - now, 1'000'000'000);
    const timespec timeout{static_cast<time_t>(wait_ns / 1'000'000'000), static_cast<long>(wait_ns % 1'000'000'000)};
    if (ppoll(fds.data(), fds.size(), &timeout, nullptr) < 0 && errno != EINTR) {
      throw std::runtime_error(fmt::format("ppoll: {}", std::strerror(errno)));
    }
    if (fds[0].revents & POLLIN) return ReceiveWaiting(NowNs());
    if (fds[1].revents & POLLIN) {
      uint64_t expirations;
      (void)!read(timer_fd_, &expirations, sizeof(expirations));
    }
    // woken early on purpose: spin to the release
    if (options_.spin_us > 0 && !queue_.empty()) {
      const int64_t release = queue_.front().release_ns;
      if (release - NowNs() <= 1000 * options_.spin_us) {
        while (NowNs() < release) {
        }
      }
    }
    // what is due first, so that arrivals' work does not delay it
    SendDue(NowNs());
    const int64_t arrived = NowNs();
    if (fds[2].revents & POLLIN) ReceiveFromDevices(arrived);
    for (std::size_t k = 0; k < slot_of.size(); ++k) {
      if ((fds[3 + k].revents & POLLIN) && flows_[slot_of[k]] != nullptr) ReceiveFromServer(slot_of[k], arrived);
    }
    SendDue(NowNs());  // a datagram with no delay leaves at once
    ArmTimer();
  }
}

void Relay::ReceiveWaiting(int64_t now_ns) {
  ReceiveFromDevices(now_ns);
  for (int i = 0; i < static_cast<int>(flows_.size()); ++i) {
    if (flows_[i] != nullptr) ReceiveFromServer(i, now_ns);
  }
}

std::string Relay::SummaryJson() const {
  std::string out = "{";
  AppendDirection(out, "up", stats_[0], queued_[0]);
  out += ", ";
  AppendDirection(out, "down", stats_[1], queued_[1]);
  int active = 0;
  for (const auto& flow : flows_) active += flow != nullptr;
  out += fmt::format(", \"flows\": {}, \"flows_now\": {}, \"refused\": {}, \"truncated\": {}, \"realtime\": {}}}",
                     flows_seen_, active, refused_, truncated_, realtime_ ? "true" : "false");
  return out;
}

}  // namespace hapticd::netem
