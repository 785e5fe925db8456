// hapticd-udp-echo: a plain UDP echo, the baseline of the latency benchmark
// (bench/run_latency.sh). It sends every datagram straight back to its sender with the
// same system calls as hapticd's realtime channel (ppoll, then one recvmmsg batch, then
// one sendmmsg), so the difference between the two is what hapticd does in between.
//   hapticd-udp-echo [--host 127.0.0.1] [--port 0] [--realtime-priority 20]
// Like hapticd's realtime thread it runs at SCHED_FIFO priority 20 when granted (0:
// normal scheduling), so neither side of the comparison is favoured by the scheduler.
// The first stdout line is JSON naming the bound endpoint, {"udp": "127.0.0.1:40125"};
// SIGINT or SIGTERM stop it (exit 0). Bad options: a message naming them, exit 2.
#include <arpa/inet.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

namespace {

constexpr int kBatch = 64;
constexpr std::size_t kBufferSize = 2048;

struct EchoOptions {
  std::string host = "127.0.0.1";
  int port = 0;
  int realtime_priority = 20;
};

constexpr std::string_view kUsage =
    "usage: hapticd-udp-echo [--host 127.0.0.1] [--port 0] [--realtime-priority 20]\n"
    "A plain UDP echo (ppoll, recvmmsg, sendmmsg): the baseline of bench/run_latency.sh.\n"
    "Prints {\"udp\": \"HOST:PORT\"} first; SIGINT or SIGTERM stop it.\n";

// The options, or an exit status (0 after --help, 2 after a bad option).
int ParseOptions(int argc, char** argv, EchoOptions& options) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view name = argv[i];
    if (name == "--help") {
      std::fwrite(kUsage.data(), 1, kUsage.size(), stdout);
      return 0;
    }
    if ((name != "--host" && name != "--port" && name != "--realtime-priority") || i + 1 >= argc) {
      std::fprintf(stderr, "hapticd-udp-echo: unknown option or missing value: %s\n", argv[i]);
      return 2;
    }
    const std::string_view value = argv[++i];
    if (name == "--host") {
      options.host = value;
      continue;
    }
    // --port in [0, 65535], --realtime-priority in [0, 99]
    int& number = name == "--port" ? options.port : options.realtime_priority;
    const int high = name == "--port" ? 65535 : 99;
    const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), number);
    if (error != std::errc() || end != value.data() + value.size() || number < 0 || number > high) {
      std::fprintf(stderr, "hapticd-udp-echo: %s is \"%s\"; it must be an integer in [0, %d]\n", argv[i - 1],
                   argv[i], high);
      return 2;
    }
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  EchoOptions options;
  if (const int status = ParseOptions(argc, argv, options); status >= 0) return status;

  // bind an IPv4 UDP socket
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(options.port));
  if (inet_pton(AF_INET, options.host.c_str(), &address.sin_addr) != 1) {
    std::fprintf(stderr, "hapticd-udp-echo: --host is \"%s\"; it must be an IPv4 address\n", options.host.c_str());
    return 2;
  }
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  socklen_t size = sizeof address;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) < 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) < 0) {
    std::fprintf(stderr, "hapticd-udp-echo: cannot bind %s:%d: %s\n", options.host.c_str(), options.port,
                 std::strerror(errno));
    return 1;
  }
  std::printf("{\"udp\": \"%s:%d\"}\n", options.host.c_str(), ntohs(address.sin_port));
  std::fflush(stdout);

  // SCHED_FIFO as hapticd's realtime thread has it (needs CAP_SYS_NICE; fine without)
  if (options.realtime_priority > 0) {
    sched_param parameters{};
    parameters.sched_priority = options.realtime_priority;
    if (sched_setscheduler(0, SCHED_FIFO, &parameters) < 0) {
      std::fprintf(stderr, "hapticd-udp-echo: SCHED_FIFO %d was not granted; normal priority\n",
                   options.realtime_priority);
    }
  }

  // SIGINT and SIGTERM arrive on a descriptor, waited for beside the socket
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigprocmask(SIG_BLOCK, &signals, nullptr);
  const int signal_fd = signalfd(-1, &signals, SFD_CLOEXEC);

  // one batch of buffers, reused: received datagrams go back out of the same slots
  std::array<std::array<uint8_t, kBufferSize>, kBatch> buffers;
  std::array<iovec, kBatch> vectors;
  std::array<sockaddr_in, kBatch> peers;
  std::array<mmsghdr, kBatch> messages{};
  for (int i = 0; i < kBatch; ++i) {
    vectors[i] = {buffers[i].data(), kBufferSize};
    messages[i].msg_hdr.msg_iov = &vectors[i];
    messages[i].msg_hdr.msg_iovlen = 1;
    messages[i].msg_hdr.msg_name = &peers[i];
    messages[i].msg_hdr.msg_namelen = sizeof peers[i];
  }
  for (;;) {
    std::array<pollfd, 2> waiters{{{fd, POLLIN, 0}, {signal_fd, POLLIN, 0}}};
    if (ppoll(waiters.data(), waiters.size(), nullptr, nullptr) < 0 && errno != EINTR) break;
    if (waiters[1].revents != 0) break;
    const int received = recvmmsg(fd, messages.data(), kBatch, MSG_DONTWAIT, nullptr);
    if (received <= 0) continue;
    // each reply is its datagram, to its sender; then the slots are ready to receive again
    for (int i = 0; i < received; ++i) vectors[i].iov_len = messages[i].msg_len;
    sendmmsg(fd, messages.data(), static_cast<unsigned>(received), MSG_DONTWAIT);
    for (int i = 0; i < received; ++i) {
      vectors[i].iov_len = kBufferSize;
      messages[i].msg_hdr.msg_namelen = sizeof peers[i];
    }
  }
  close(signal_fd);
  close(fd);
  return 0;
}
