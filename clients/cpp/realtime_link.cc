#include "clients/cpp/realtime_link.h"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <string>
#include <system_error>

#include "clients/cpp/tick_schedule.h"
#include "hapticd/v1/hapticd.pb.h"

namespace hapticd::proxy {
namespace {

constexpr int64_t kNsPerSecond = 1'000'000'000;

std::string EndpointText(const asio::ip::udp::endpoint& endpoint) {
  return endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
}

[[noreturn]] void ThrowSystemError(const std::string& what) {
  throw std::system_error(errno, std::generic_category(), what);
}

// The kernel's SO_TIMESTAMPNS arrival stamp of a received message (CLOCK_REALTIME,
// ns), or 0 when it carries none.
int64_t ArrivalStampNs(msghdr& message) {
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec stamp;
      std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
      return int64_t{stamp.tv_sec} * kNsPerSecond + stamp.tv_nsec;
    }
  }
  return 0;
}

}  // namespace

LinkCounters& LinkCounters::operator+=(const LinkCounters& other) {
  sent += other.sent;
  send_errors += other.send_errors;
  answered += other.answered;
  late += other.late;
  stale += other.stale;
  bad += other.bad;
  predicted += other.predicted;
  return *this;
}

ServerEnd& ServerEnd::operator+=(const ServerEnd& other) {
  energy_in += other.energy_in;
  energy_out += other.energy_out;
  commands_held += other.commands_held;
  commands_sent += other.commands_sent;
  return *this;
}

RealtimeLink::RealtimeLink(uint32_t session_id, const net::SessionKey& key,
                           const asio::ip::udp::endpoint& endpoint, LinkPeer peer)
    : session_id_(session_id), key_(key), peer_(peer) {
  const std::string where = EndpointText(endpoint);
  fd_ = socket(endpoint.protocol().family(), SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) ThrowSystemError("cannot open a UDP socket for " + where);
  // the kernel stamps each datagram's arrival: the wire's round trip, without our wake-up
  const int on = 1;
  if (setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) < 0 ||
      connect(fd_, endpoint.data(), static_cast<socklen_t>(endpoint.size())) < 0) {
    const int error = errno;
    close(fd_);
    errno = error;
    ThrowSystemError("cannot connect a UDP socket to " + where);
  }
}

RealtimeLink::~RealtimeLink() { close(fd_); }

bool RealtimeLink::Send(net::DeviceStateSample& state) {
  state.session_id = session_id_;
  state.sequence = ++last_sequence_;
  const std::size_t slot = last_sequence_ % kWindow;
  replied_[slot] = false;
  send_real_ns_[slot] = 0;
  wait_ = Wait::kNone;
  // stamped before encoding: the round trip includes our own encode and tag
  const int64_t send_real_ns = RealtimeNowNs();
  send_mono_ns_ = MonotonicNowNs();
  state.send_time_ns = static_cast<uint64_t>(send_mono_ns_);
  const std::size_t size = net::EncodeState(state, key_, send_buffer_);
  // a state that does not fit, or a send the kernel refuses, is not waited for
  if (size == 0 || send(fd_, send_buffer_.data(), size, MSG_DONTWAIT) != static_cast<ssize_t>(size)) {
    ++counters_.send_errors;
    return false;
  }
  ++counters_.sent;
  send_real_ns_[slot] = send_real_ns;
  wait_ = Wait::kWaiting;
  return true;
}

bool RealtimeLink::Drain() {
  // stop at the answer: what is left stays queued for the next call (epoll reports it)
  const bool was_answered = answered();
  while (was_answered || !answered()) {
    iovec buffer{receive_buffer_.data(), receive_buffer_.size()};
    msghdr message{};
    message.msg_iov = &buffer;
    message.msg_iovlen = 1;
    message.msg_control = control_buffer_.data();
    message.msg_controllen = control_buffer_.size();
    const ssize_t size = recvmsg(fd_, &message, MSG_DONTWAIT);
    if (size < 0) {
      if (errno == EINTR) continue;
      // an ICMP error for an earlier send (no server there): reported once, then gone
      if (errno == ECONNREFUSED) {
        ++counters_.send_errors;
        continue;
      }
      // nothing more queued (EAGAIN), or an error retrying cannot fix
      break;
    }
    const auto length = std::min(static_cast<std::size_t>(size), receive_buffer_.size());
    Accept({receive_buffer_.data(), length}, (message.msg_flags & MSG_TRUNC) != 0, ArrivalStampNs(message));
  }
  return answered();
}

void RealtimeLink::Expire() {
  if (wait_ == Wait::kWaiting) wait_ = Wait::kExpired;
}

bool RealtimeLink::Parse(std::span<const uint8_t> datagram) {
  if (peer_ == LinkPeer::kServer) return net::ParseCommand(datagram, incoming_) == net::DatagramError::kNone;
  // echo: our own state back, read as a command that renders nothing and holds the pose
  if (net::ParseState(datagram, echoed_) != net::DatagramError::kNone) return false;
  incoming_ = net::DeviceCommandSample{};
  incoming_.session_id = echoed_.session_id;
  incoming_.sequence = echoed_.sequence;
  incoming_.echo_send_time_ns = echoed_.send_time_ns;
  incoming_.p_command_W = echoed_.p_WD;
  incoming_.q_command_W = echoed_.q_WD;
  return true;
}

void RealtimeLink::Accept(std::span<const uint8_t> datagram, bool truncated, int64_t arrival_real_ns) {
  // size, tag, message, session: anything failing one is not ours to trust
  if (truncated || datagram.size() > net::kMaxDatagramSize || !net::CheckTag(datagram, key_) ||
      !Parse(datagram) || incoming_.session_id != session_id_) {
    ++counters_.bad;
    return;
  }
  // an authentic word that the session ended: the device must stop rendering it
  ended_flags_ |= incoming_.flags & (v1::COMMAND_FLAGS_SESSION_CLOSED | v1::COMMAND_FLAGS_SESSION_TIMED_OUT);
  if (fragment_sink_ != nullptr && incoming_.model.count != 0) fragment_sink_->Offer(incoming_.model);
  incoming_.model = {};  // its bytes are the receive buffer's, gone with the next datagram
  // the server's end, as it reports it
  if (std::isfinite(incoming_.energy_in)) server_end_.energy_in = std::max(server_end_.energy_in, incoming_.energy_in);
  if (std::isfinite(incoming_.energy_out)) {
    server_end_.energy_out = std::max(server_end_.energy_out, incoming_.energy_out);
  }
  server_end_.commands_held = std::max(server_end_.commands_held, incoming_.commands_held);
  server_end_.commands_sent = std::max(server_end_.commands_sent, incoming_.command_number);
  const uint64_t sequence = incoming_.sequence;
  // an answer to a state never sent
  if (sequence > last_sequence_) {
    ++counters_.bad;
    return;
  }
  // a deadband's prediction on a state already answered (or held back)
  if (incoming_.flags & v1::COMMAND_FLAGS_PREDICTED) {
    ++counters_.predicted;
    TakeIfNewest();
    return;
  }
  // the server's watchdog commands (sequence 0), answers too old to place, duplicates,
  // and answers to states whose send failed
  const std::size_t slot = sequence % kWindow;
  if (sequence == 0 || last_sequence_ - sequence >= kWindow || replied_[slot] || send_real_ns_[slot] == 0) {
    ++counters_.stale;
    return;
  }
  replied_[slot] = true;
  TakeIfNewest();
  if (wire_rtt_sink_ != nullptr && arrival_real_ns != 0) wire_rtt_sink_->Record(arrival_real_ns - send_real_ns_[slot]);
  // the last state's answer within its wait is the one the loop renders
  if (sequence == last_sequence_ && wait_ == Wait::kWaiting) {
    command_ = incoming_;
    wait_ = Wait::kAnswered;
    ++counters_.answered;
    rtt_ns_ = MonotonicNowNs() - send_mono_ns_;
    wire_rtt_ns_ = arrival_real_ns != 0 ? arrival_real_ns - send_real_ns_[slot] : 0;
    return;
  }
  ++counters_.late;
}

void RealtimeLink::TakeIfNewest() {
  const bool numbered = incoming_.command_number != 0 && newest_.command_number != 0;
  if (numbered ? incoming_.command_number > newest_.command_number : incoming_.sequence > newest_.sequence) {
    newest_ = incoming_;
    fresh_ = true;
  }
}

LinkSet::LinkSet(std::span<RealtimeLink* const> links)
    : links_(links.begin(), links.end()), counted_(links.size()), events_(std::max<std::size_t>(1, links.size())) {
  epoll_fd_ = epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) ThrowSystemError("cannot create an epoll instance for the links");
  for (std::size_t i = 0; i < links_.size(); ++i) {
    epoll_event interest{};
    interest.events = EPOLLIN;
    interest.data.u32 = static_cast<uint32_t>(i);
    if (epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, links_[i]->fd(), &interest) < 0) {
      const int error = errno;
      close(epoll_fd_);
      errno = error;
      ThrowSystemError("cannot watch link " + std::to_string(i) + " with epoll");
    }
  }
}

LinkSet::~LinkSet() { close(epoll_fd_); }

int LinkSet::AwaitAll(int64_t deadline_ns) {
  const int count = static_cast<int>(links_.size());
  int answered = 0;
  std::fill(counted_.begin(), counted_.end(), 0);
  // one pass at least, then until everything is answered or the time is up
  for (;;) {
    const int64_t left_ns = std::max<int64_t>(0, deadline_ns - MonotonicNowNs());
    int ready;
    if (have_pwait2_) {
      const timespec timeout{static_cast<time_t>(left_ns / kNsPerSecond), static_cast<long>(left_ns % kNsPerSecond)};
      ready = epoll_pwait2(epoll_fd_, events_.data(), count, &timeout, nullptr);
      // an older kernel: whole milliseconds, rounded up
      if (ready < 0 && errno == ENOSYS) {
        have_pwait2_ = false;
        continue;
      }
    } else {
      ready = epoll_wait(epoll_fd_, events_.data(), count, static_cast<int>((left_ns + 999'999) / 1'000'000));
    }
    for (int e = 0; e < ready; ++e) {
      const uint32_t i = events_[e].data.u32;
      if (links_[i]->Drain() && !counted_[i]) {
        counted_[i] = 1;
        ++answered;
      }
    }
    // an interrupted wait (a signal, ready < 0) goes round again while time is left
    if (answered == count || left_ns == 0) break;
  }
  return answered;
}

}  // namespace hapticd::proxy
