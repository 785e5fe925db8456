// hapticd-netem: the impairment relay (server/netem/relay.h; --help for its flags).
// Exit 0 after SIGINT, SIGTERM or --duration-s; 2 on bad flags (a message naming the
// flag); 1 when it cannot bind.
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "server/netem/netem_options.h"
#include "server/netem/relay.h"

int main(int argc, char** argv) {
  using namespace hapticd::netem;
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  NetemOptions options;
  try {
    options = ParseNetemOptions(args);
  } catch (const OptionsError& error) {
    std::fprintf(stderr, "hapticd-netem: %s\n", error.what());
    return 2;
  }
  if (options.help) {
    const std::string_view usage = Usage();
    std::fwrite(usage.data(), 1, usage.size(), stdout);
    return 0;
  }
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  sigprocmask(SIG_BLOCK, &stop, nullptr);
  const int stop_fd = signalfd(-1, &stop, SFD_CLOEXEC);
  try {
    Relay relay(options);
    std::printf("{\"listen\": \"%s\", \"forward\": \"%s:%d\", \"seed\": %llu, \"realtime\": %s}\n",
                relay.listen_endpoint().c_str(), options.forward.host.c_str(), options.forward.port,
                static_cast<unsigned long long>(options.seed), relay.realtime() ? "true" : "false");
    std::fflush(stdout);
    relay.Run(stop_fd);
    std::printf("%s\n", relay.SummaryJson().c_str());
    std::fflush(stdout);
  } catch (const std::runtime_error& error) {
    std::fprintf(stderr, "hapticd-netem: %s\n", error.what());
    return 1;
  }
  return 0;
}
